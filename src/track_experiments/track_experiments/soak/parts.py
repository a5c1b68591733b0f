"""The soak's three parts (see the package docstring); each returns one ``Row`` per process it judged."""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass
from pathlib import Path

from track_experiments.soak.bags import read_bag
from track_experiments.soak.probe import ClockProbe
from track_experiments.soak.procs import Proc, launch_cmd, node_cmd

CONCURRENT = {'demo': '^/demo/', 'sonar': '^/sonar/', 'slam_sim': '^/slam/'}
CLOCK_LINE = r'/clock from'  # the launcher prints it when its clock starts: every node is up
LONG = '100000'  # --duration [node s]: the runs end by SIGTERM, not by their duration
LOOP_BAG_S = 10.0  # [node s] the bag recorded for the loop part
LOOP_RATE = 4.0
RESTART_NS = 1_000_000_000  # /clock back by more than this: the bag started again
LOOP_SHARE = 0.8  # a loop survives when at least this share of its reports became tracks


@dataclass
class Row:
    part: str
    run: str
    exit: int | None
    ready_s: float | None = None  # wall s from start to "up" (the first /clock or the first output)
    stop_s: float | None = None  # wall s from SIGTERM to exit
    messages: int = 0  # recorded (or, for the loop part, tracks received)
    lost: int | None = None  # the recorder's own count, or reports that did not become tracks
    problem: str = ''  # empty: it survived

    @property
    def survived(self) -> bool:
        return not self.problem


def _stop_all(procs: list[Proc]) -> None:
    for p in procs:
        p.send_term()
    for p in procs:
        p.terminate()


def _bag_row(part: str, run: str, proc: Proc, bag: Path, regex: str, ready: float | None) -> Row:
    row = Row(part, run, proc.popen.returncode, ready, proc.stop_s)
    verdict = read_bag(bag, regex)
    recorded = proc.recorded()
    row.messages = verdict.messages
    row.lost = None if recorded is None else recorded[1]
    problems = []
    if ready is None:
        problems.append('never started its clock')
    if proc.killed or row.exit != 0:
        problems.append(f'exit {row.exit}' + (' (killed after SIGTERM)' if proc.killed else ''))
    if verdict.problem:
        problems.append(verdict.problem)
    if verdict.foreign:
        problems.append(f'foreign topics {", ".join(verdict.foreign)}')
    if recorded is None:
        problems.append('no recorder summary line')
    elif recorded[1]:
        problems.append(f'{recorded[1]} messages lost')
    if not verdict.problem and not verdict.messages:
        problems.append('empty bag')
    if problems:
        row.problem = '; '.join(problems) + (f' [{proc.tail(1)[:160]}]' if row.exit else '')
    return row


def concurrent(out: Path, env: dict[str, str], run_s: float, timeout: float) -> list[Row]:
    """Three recorded scenarios at once on one domain, stopped by SIGTERM after ``run_s`` of clock."""
    procs = {sc: Proc(sc, launch_cmd(sc, '--record', str(out / f'concurrent-{sc}'), '--duration', LONG),
                      out / f'concurrent-{sc}.log', env) for sc in CONCURRENT}
    try:
        ready = {sc: p.wait_for(CLOCK_LINE, timeout) for sc, p in procs.items()}
        time.sleep(run_s)
    finally:  # interrupted too (Ctrl-C, a test's timeout): no child outlives the soak
        _stop_all(list(procs.values()))
    return [_bag_row('concurrent', sc, p, out / f'concurrent-{sc}', CONCURRENT[sc], ready[sc])
            for sc, p in procs.items()]


def bringup(out: Path, env: dict[str, str], sensors: int, run_s: float, timeout: float) -> list[Row]:
    """An IDSQ field of ``sensors`` nodes in one process: time to the first /clock, then SIGTERM."""
    from track_nodes.idsq.scenario_files import idsq_yaml

    scenario = out / f'idsq{sensors}.yaml'
    scenario.write_text(idsq_yaml(n_sensors=sensors, duration=float(LONG)))
    bag = out / f'bringup-{sensors}'
    proc = Proc(f'idsq{sensors}', launch_cmd(str(scenario), '--record', str(bag)), out / f'bringup-{sensors}.log',
                env)
    try:
        ready = proc.wait_for(CLOCK_LINE, timeout)
        if ready is not None:
            time.sleep(run_s)
    finally:
        _stop_all([proc])
    return [_bag_row('bringup', f'{sensors} sensors', proc, bag, '^/idsq/', ready)]


def loop(out: Path, env: dict[str, str], loops: int, timeout: float) -> list[Row]:
    """A recorded demo bag looped ``loops`` times into a demo_tracker process on sim time."""
    from track_nodes.launch.scenario import load_scenario

    source = out / 'loop-source'
    rec = Proc('record', launch_cmd('demo', '--record', str(source), '--duration', f'{LOOP_BAG_S:g}'),
               out / 'loop-source.log', env)
    if rec.popen.wait(timeout=timeout) != 0 or not (source / 'metadata.yaml').exists():
        return [Row('loop', 'record the source bag', rec.popen.returncode, problem=rec.tail(2) or 'no bag')]
    reports = read_bag(source, '^/demo/').counts.get('/demo/reports', 0)
    params = str(load_scenario('demo').path)
    with _TrackProbe(int(env.get('ROS_DOMAIN_ID', '0'))) as probe:
        tracker = Proc('demo_tracker', node_cmd('demo_tracker', '--ros-args', '--params-file', params,
                                                '-r', '__node:=soak_tracker', '-p', 'use_sim_time:=true'),
                       out / 'loop-tracker.log', env)
        player = Proc('player', node_cmd('player', str(source), '--loop', '--topics', '/demo/reports',
                                         '--rate', f'{LOOP_RATE:g}', '--wait', '30'), out / 'loop-player.log', env)
        try:
            deadline = time.monotonic() + timeout + loops * 3 * LOOP_BAG_S / LOOP_RATE
            first = probe.spin_until(lambda: probe.tracks_in(0) > 0, deadline)
            ready = None if not first else time.monotonic() - tracker.t_start
            probe.spin_until(lambda: probe.restarts >= loops, deadline)
        finally:
            _stop_all([player, tracker])
    counts = [probe.tracks_in(k) for k in range(loops)]
    row = Row('loop', f'{loops} loops of {reports} reports', max(player.popen.returncode, tracker.popen.returncode,
                                                                  key=abs), ready,
              max(player.stop_s or 0.0, tracker.stop_s or 0.0), sum(counts), loops * reports - sum(counts))
    problems = [f'loop {k + 1}: {n} tracks' for k, n in enumerate(counts) if n < LOOP_SHARE * reports]
    problems += [f'{p.label} exit {p.popen.returncode}' for p in (player, tracker) if p.popen.returncode != 0]
    if probe.restarts < loops:
        problems.insert(0, f'only {probe.restarts} of {loops} restarts seen')
    if probe.bad:
        problems.append(f'{probe.bad} non-finite tracks')
    row.problem = '; '.join(problems)
    return [row]


class _TrackProbe(ClockProbe):
    """Counts /demo/track per loop (a /clock going back opens one)."""

    def __init__(self, domain_id: int) -> None:
        super().__init__(domain_id)
        self.restarts, self.bad = 0, 0
        self._counts: dict[int, int] = {}
        self._last_clock: int | None = None

    def subscribe(self, node) -> None:
        from nav_msgs.msg import Odometry

        from track_msgs_py.qos import ESTIMATE_QOS

        node.create_subscription(Odometry, '/demo/track', self._on_track, ESTIMATE_QOS)

    def _on_clock(self, msg) -> None:
        t = msg.clock.sec * 1_000_000_000 + msg.clock.nanosec
        if self._last_clock is not None and t < self._last_clock - RESTART_NS:
            self.restarts += 1
        self._last_clock = t

    def _on_track(self, msg) -> None:
        p = msg.pose.pose.position
        if not (math.isfinite(p.x) and math.isfinite(p.y)):
            self.bad += 1
        self._counts[self.restarts] = self._counts.get(self.restarts, 0) + 1

    def tracks_in(self, k: int) -> int:
        return self._counts.get(k, 0)


def soak_env(domain: str | None) -> dict[str, str]:
    """The environment of every soak process: the user's, with ``domain`` as ROS_DOMAIN_ID if given."""
    env = {**os.environ, 'PYTHONUNBUFFERED': '1'}
    if domain is not None:
        env['ROS_DOMAIN_ID'] = domain
    return env

"""Launcher: ``python -m track_nodes.launch SCENARIO [--record [NAME]] [--duration S] [--processes]
[--hosts N] [--params FILE] [--rate R] [--epoch E] [--network] [--watchdog S]``.

Reads ``config/SCENARIO.yaml`` (see ``track_nodes.launch.scenario``) and runs its nodes, either all in
this process on one MultiThreadedExecutor (default) or one process per node (``--processes``),
optionally spread round-robin over N simulated hosts that the launcher creates and always removes
(``--hosts N``, root only; see ``track_nodes.launch.hosts``).

Time: with ``--rate R > 0`` (default: the scenario's ``rate``) every node gets ``use_sim_time:=true``
and the launcher publishes ``/clock`` from the epoch E (``--epoch``: ``now``, the whole minute of
wall time when the clock starts; whole seconds since 1970, at least 1; or an ISO date in UTC), in
steps of min(R·CLOCK_TICK, MAX_CLOCK_STEP) s, at most R× wall time. In one process the clock runs
in lock-step (every callback that became ready runs before the next step), so a seed and an epoch
reproduce every payload on any machine; with ``--processes`` it is paced by R, held at the epoch
while discovery settles and held back while a periodic topic is a step behind (``pacing.Cadence``).
``--rate 0`` runs on wall time.

The clock starts once every node is up and every ``/clock`` subscription (and, when recording, the
recorder's) has matched; it stops exactly at ``--duration``; after a grace period every node stops
(the recorder closes its bag); Ctrl-C, SIGTERM and SIGHUP alike. A wall-time bag replay ends when
the bag is played and the recorded topics are quiet for ``QUIET`` s (``_drain``).

Isolation (``isolation``): localhost-only discovery (``--network`` opens it), a ROS domain of its
own when ROS_DOMAIN_ID is unset, no start on a domain where another run is (``twin``), a stop on a
foreign /clock or publisher. A watchdog (``lockstep``, ``--watchdog S``) stops a run whose clock
has not advanced, naming the callback it waits for; exit 1. In full: docs/MODULES.md, "The launcher
in full".
"""

from __future__ import annotations

import argparse
import contextlib
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from datetime import datetime
from pathlib import Path

import rclpy
from rclpy.context import Context
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter

from track_msgs_py.topics import READY
from track_nodes.bag.player import PlayerNode
from track_nodes.base import EXIT_BAD_INPUT, remember_args, shared_names_problem
from track_nodes.base.epoch import EpochError
from track_nodes.base.epoch import parse_epoch as _parse_epoch
from track_nodes.launch.cli import parse_args
from track_nodes.launch.graph import LauncherNode, listing, ready_deadline
from track_nodes.launch.hosts import Hosts, unavailable
from track_nodes.launch.isolation import ForeignCheck, Isolation
from track_nodes.launch.lockstep import Watchdog, run_ready
from track_nodes.launch.pacing import Cadence, clock_step, epoch_line, epoch_now, node_time
from track_nodes.launch.preflight import bag_problem, params_problem
from track_nodes.launch.processes import (
    ended_early,
    exit_text,
    failed_children,
    processes_cpu,
    say_cpu,
    spawn_nodes,
    stop_processes,
)
from track_nodes.launch.scenario import Scenario, ScenarioError, load_scenario
from track_nodes.launch.tuning import (
    CLOCK_TICK,
    DRAIN_MAX,
    GRACE,
    MAX_DOMAIN_ID,
    QUIET,
    SETTLE,
    SETTLE_PROCESSES,
    WATCH_EVERY,
)
from track_nodes.launch.twin import probe, refuse_twins

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


class LaunchError(RuntimeError):
    """The scenario could not be started; the message is one line."""


def _parse(argv: list[str] | None) -> argparse.Namespace:
    return parse_args(argv, __doc__.split('\n\n')[1])


def parse_epoch(text: str) -> int | None:
    """``--epoch``: whole seconds since 1970, or None for 'now' (fixed when the clock starts)."""
    try:
        return _parse_epoch(text)
    except EpochError as exc:
        raise LaunchError(str(exc)) from None


class Launch:
    def __init__(self, scenario: Scenario, args: argparse.Namespace) -> None:
        self.sc = scenario
        opts = scenario.options
        self.rate = float(args.rate if args.rate is not None else opts.get('rate', 0.0))
        self.duration = args.duration if args.duration is not None else opts.get('duration')
        if not self.rate >= 0:
            raise LaunchError(f'--rate must be >= 0, got {self.rate}')
        if self.duration is not None and not float(self.duration) > 0:
            raise LaunchError(f'--duration must be > 0, got {self.duration}')
        self.sim = self.rate > 0
        self.epoch = parse_epoch(str(args.epoch))  # None: now, fixed when the clock starts
        self.clock_said = False
        self.params_files = [str(scenario.path)]
        if (problem := params_problem(args.params, scenario)) is not None:  # preflight.py
            raise LaunchError(problem)
        self.params_files += [str(p.resolve()) for p in args.params]
        self.bag: Path | None = None
        if args.record is not None:
            name = args.record or f'{scenario.name}-{datetime.now():%Y%m%d-%H%M%S}'
            self.bag = Path(name) if '/' in name else Path('bags') / name
            if self.bag.exists():
                raise LaunchError(f'{self.bag}: bag exists already, not overwriting (choose another --record NAME)')
            if (problem := bag_problem(self.bag)) is not None:  # preflight.py: the directory, writable, room
                raise LaunchError(problem)
        self.record_regex = str(opts.get('record_regex', '.*'))
        self.network, self.watchdog_s = args.network, args.watchdog
        if self.watchdog_s is not None and not self.watchdog_s > 0:
            raise LaunchError(f'--watchdog must be > 0 s, got {self.watchdog_s}')
        self.dog: Watchdog | None = None
        self.clock_cpu: tuple[float, float] | None = None  # (wall, CPU s) at the clock's start, --processes
        self.lockstep = False
        self.nodes: list[Node] = []
        self.replay_done = False
        self.early: list[subprocess.Popen] = []  # --processes: the children that ended while the run went on
        self.started = False  # the run's clock (or wall-time drive) has started: its bag holds the run

    # -- the two ways of running the nodes ------------------------------------------------
    def run(self, processes: bool, n_hosts: int = 0) -> int:
        domain = os.environ.get('ROS_DOMAIN_ID', '').strip()
        if domain and not (domain.isdigit() and int(domain) <= MAX_DOMAIN_ID):
            # Fast DDS exit(1)s inside the first node's creation: no message of ours, namespaces left behind
            raise LaunchError(f'ROS_DOMAIN_ID={domain}: Fast DDS needs 0..{MAX_DOMAIN_ID} (its UDP ports)')
        self._watch_sigint()
        try:
            isolation = Isolation(self.network).acquire()
        except RuntimeError as exc:
            raise LaunchError(str(exc)) from None
        print(isolation.describe(), flush=True)
        names = [s.name for s in self.sc.nodes] + ['recorder'] * (self.bag is not None)
        if not (isolation.chosen or n_hosts) and (found := probe(names, self.sim)) is not None:
            raise LaunchError(found)  # another run on the domain the user set: refused before anything exists
        with isolation:
            return self._run_on_hosts(processes, n_hosts)

    def _run_on_hosts(self, processes: bool, n_hosts: int) -> int:
        if not n_hosts:
            return self._run(processes, None)
        if not processes or n_hosts < 1:
            raise LaunchError('--hosts N needs --processes and N >= 1')
        if (reason := unavailable()) is not None:
            raise LaunchError(f'--hosts: {reason}')
        with Hosts(n_hosts) as hosts:
            print(f'hosts: {n_hosts} namespaces {hosts.tag}-*, {hosts.subnet}, set up in {hosts.setup_s:.2f} s',
                  flush=True)
            os.environ.update(hosts.server_env())  # the launcher's own participant: the run's discovery server
            return self._run(processes, hosts)

    def _run(self, processes: bool, hosts: Hosts | None) -> int:
        self.context = context = Context()
        self.lockstep = self.sim and not processes
        ros_args = ['--ros-args', *[a for f in self.params_files for a in ('--params-file', f)]]
        rclpy.init(args=ros_args if not processes else None, context=context)
        remember_args(context, ros_args if not processes else None)  # node parameter names (base/names.py)
        launcher = LauncherNode(context)
        executor = MultiThreadedExecutor(context=context)
        executor.add_node(launcher)
        nodes, children = [], []
        try:
            if processes:
                children = spawn_nodes(self.sc.nodes, self.params_files, self.sim, self.bag, self.record_regex,
                                       hosts)
            else:
                nodes = self.nodes = self._create_all(context)
                for node in nodes:
                    executor.add_node(node)
            self._wait_ready(launcher, executor, children)
            self._deferring = True  # a stop is taken between two callbacks from here (_on_stop_signal)
            try:
                self._drive(launcher, executor, children)
            finally:
                self._deferring = False
        except KeyboardInterrupt:
            pass
        finally:
            self._stopping = True  # a stop signal from here on is noted, never raised (_on_stop_signal)
            if self.dog is not None:
                self.dog.watching = False  # the clock has stopped: the drain and the grace have their own bounds
            with contextlib.suppress(KeyboardInterrupt):
                if children or self.replay_done:
                    self._drain(launcher, executor)
                say_cpu(children, self.clock_cpu)  # --processes: one line
                self._pump(executor, time.monotonic() + GRACE)  # messages in flight reach the recorder
            stop_processes(children)
            # The main thread is the only one that hands work to the pool; drain the pool before
            # shutting the executor down (rclpy 7.1's shutdown does not wait for running callbacks).
            pool = getattr(executor, '_executor', None)
            if pool is not None:
                pool.shutdown(wait=True)
            executor.shutdown(timeout_sec=5.0)
            for node in nodes:
                node.destroy_node()  # the recorder closes its bag here
            launcher.destroy_node()
            context.try_shutdown()
            if self.dog is not None:
                self.dog.stop()
        own = max((getattr(node, 'exit_code', 0) for node in nodes), default=0)  # e.g. the recorder's full disk
        return EXIT_BAD_INPUT if failed_children(children, self.early) else own

    def _replayed(self) -> bool:
        """Wall time: every player among the nodes has played its bag (a looped one never has)."""
        players = [n for n in self.nodes if isinstance(n, PlayerNode)]
        return bool(players) and all(p.done.is_set() for p in players)

    def _drain(self, launcher: LauncherNode, executor: MultiThreadedExecutor) -> None:
        """--processes, or a played bag: after the clock stopped, wait until the nodes' work is done.

        They cannot be observed directly, but every result they produce is a message: once no
        watched topic has delivered anything for ``QUIET`` wall seconds, the work queued up to the
        last clock tick is done, whatever the machine's load (at most ``DRAIN_MAX`` seconds).
        """
        deadline = time.monotonic() + DRAIN_MAX
        launcher.watch(self.record_regex)
        launcher.last_message = time.monotonic()
        while self.context.ok() and time.monotonic() < deadline:
            if time.monotonic() - launcher.last_message >= QUIET:
                return
            self._pump(executor, time.monotonic() + 0.1)

    def _pump(self, executor: MultiThreadedExecutor, deadline: float) -> None:
        """Hand ready callbacks to the executor's threads until ``deadline`` (monotonic s); in
        lock-step run them inline instead (see ``lockstep``: no callback may outlive its step)."""
        if self.lockstep:
            run_ready(executor, self.context, deadline, self._interrupted, self.dog)
            return
        while self.context.ok():
            left = deadline - time.monotonic()
            if left <= 0:
                return
            if self._interrupted():
                raise KeyboardInterrupt  # a stop signal, taken between two turns
            executor.spin_once(timeout_sec=min(left, 0.005))

    def _run_until_idle(self, executor: MultiThreadedExecutor) -> None:
        """Lock-step: run ready callbacks inline, in order, until none is ready twice in a row."""
        run_ready(executor, self.context, None, self._interrupted, self.dog)

    def _watch_sigint(self) -> None:
        """SIGTERM and SIGHUP stop the run exactly like SIGINT (a KeyboardInterrupt: nodes stopped,
        bag closed, summary). Every signal is noted in a socket (``signal.set_wakeup_fd``): a Ctrl-C
        that lands inside a callback can surface as another error (rclpy's take: "Unable to convert
        call argument"), and the launcher must still stop cleanly then."""
        self._sig_r, self._sig_w = socket.socketpair()
        for sock in (self._sig_r, self._sig_w):
            sock.setblocking(False)
        self._sigint = self._deferring = self._cut = self._stopping = False
        with contextlib.suppress(ValueError):  # not the main thread: no watch
            signal.set_wakeup_fd(self._sig_w.fileno(), warn_on_full_buffer=False)
            for sig in STOP_SIGNALS:
                signal.signal(sig, self._on_stop_signal)

    def _on_stop_signal(self, signum: int, frame) -> None:
        """While the clock runs a stop is taken at the loop's next turn, between two callbacks: a
        KeyboardInterrupt raised inside one (the recorder's, holding its writer's lock) could leave
        teardown waiting on that lock until the process is killed, its bag unreadable. During bring-up,
        and from the watchdog (a callback that does not return must be cut, once), it is a
        KeyboardInterrupt at once. Only the first stop raises: a second one while it is taken, or any
        once teardown began, is noted (it cuts the drain short) and changes nothing else."""
        first, self._sigint = not self._sigint, True
        if getattr(getattr(self, 'dog', None), 'stalled', None) and not self._cut:
            self._cut = True
            raise KeyboardInterrupt
        if first and not self._deferring and not self._stopping:
            raise KeyboardInterrupt

    def _interrupted(self) -> bool:
        with contextlib.suppress(BlockingIOError, AttributeError, OSError):
            noted = self._sig_r.recv(64)  # read once: every signal number noted since the last call
            self._sigint = self._sigint or any(s in noted for s in STOP_SIGNALS)
        return getattr(self, '_sigint', False)

    def _overrides(self) -> list[Parameter]:
        return [Parameter('use_sim_time', value=self.sim)]

    def _create_all(self, context: Context) -> list[Node]:
        """Build every node of the scenario (then the recorder) in this process; each announces itself.

        Ctrl-C while building (KeyboardInterrupt between two of rclpy's C calls: node creation never
        holds off signals for more than a few ms) says so in one line, destroys the nodes built so far
        (seconds for a hundred: each deletion in rmw_fastrtps costs in proportion to what is left),
        then stops.
        """
        nodes = []
        total = len(self.sc.nodes) + (self.bag is not None)
        try:
            for spec in self.sc.nodes:
                cls = spec.node_class()
                try:
                    nodes.append(cls(node_name=spec.name, context=context, parameter_overrides=self._overrides()))
                except ValueError as exc:
                    raise LaunchError(f'{spec.name}: {exc}') from None
            if self.bag is not None:
                from track_nodes.bag.recorder import RecorderNode

                try:  # a disk that filled since the preflight: one line, the bag removed (main)
                    nodes.append(RecorderNode(context=context, parameter_overrides=[
                        *self._overrides(), Parameter('bag', value=str(self.bag)),
                        Parameter('regex', value=self.record_regex), Parameter('discard_empty', value=True)]))
                except (ValueError, OSError) as exc:
                    raise LaunchError(f'recorder: {exc}') from None
            if (problem := shared_names_problem(nodes, self.params_files)) is not None:  # base/names.py
                raise LaunchError(problem)
        except (LaunchError, KeyboardInterrupt) as exc:
            if isinstance(exc, KeyboardInterrupt):
                print(f'track_nodes.launch: Ctrl-C while building node {len(nodes) + 1} of {total}: stopping '
                      f'(destroying the {len(nodes)} built)', file=sys.stderr, flush=True)
            for node in reversed(nodes):
                node.destroy_node()
            raise
        return nodes

    # -- start, clock, stop ---------------------------------------------------------------
    def _wait_ready(self, launcher: LauncherNode, executor: MultiThreadedExecutor,
                    children: list[subprocess.Popen]) -> None:
        """Until every node has announced itself (``base/ready.py``), the recorder subscribed to every
        recordable topic and every /clock subscription matched; a deadline from the node count."""
        names = [s.name for s in self.sc.nodes] + (['recorder'] if self.bag is not None else [])
        timeout, why = ready_deadline(len(names), bool(children))
        deadline = time.monotonic() + timeout
        while True:
            for child in children:
                if child.poll() is not None:
                    raise LaunchError(f'{child.label} {exit_text(child)} at start (pid {child.pid})')
            self._refuse_twins(launcher, names, children)
            missing = launcher.nodes_missing(names)
            if missing:
                missing = [f'the announcement of {listing(missing)} on {READY} ({len(missing)} of {len(names)} '
                           'nodes)']
            elif self.bag is not None and (unrecorded := launcher.topics_unrecorded(self.record_regex, 'recorder')):
                missing = [f'the recorder to subscribe to {listing(unrecorded)} ({len(unrecorded)} topics)']
            elif self.sim and (unmatched := launcher.clock_unmatched()):
                missing = [f'{unmatched} /clock subscription(s) to match']
            if not missing:
                print(f'ready: {len(names)} nodes in {time.monotonic() - deadline + timeout:.1f} s', flush=True)
                break
            if time.monotonic() > deadline or not self.context.ok():
                raise LaunchError(f'not ready after {timeout:.0f} s ({why}): waiting for {missing[0]}')
            self._pump(executor, time.monotonic() + 0.05)
        if not (children and self.sim):
            self._pump(executor, time.monotonic() + (SETTLE_PROCESSES if children else SETTLE))
            self._refuse_twins(launcher, names, children)  # one heard while discovery settled: still before the start
            return
        # Other processes run their first callback when their CPU share allows (seen: up to 2 s late
        # with 25 processes on 2 cores, and the origin was as late): the clock is held at the epoch
        # while discovery settles, so each node's first reading, which fixes its step origin
        # (FixedRateSteps), is the epoch itself.
        settled = time.monotonic() + SETTLE_PROCESSES
        while time.monotonic() < settled and self.context.ok():
            launcher.publish_clock(self._epoch_ns())
            self._pump(executor, time.monotonic() + CLOCK_TICK)

    def _refuse_twins(self, launcher: LauncherNode, names: list[str], children: list[subprocess.Popen]) -> None:
        if not children and (line := refuse_twins(launcher, names)) is not None:  # one process (twin.py)
            raise LaunchError(line)

    def _epoch_ns(self) -> int:
        if self.epoch is None:
            self.epoch = epoch_now()
        if not self.clock_said:
            self.clock_said = True
            print(epoch_line(self.epoch), flush=True)
        return self.epoch * 1_000_000_000

    def _drive(self, launcher: LauncherNode, executor: MultiThreadedExecutor,
               children: list[subprocess.Popen]) -> None:
        self.started = True
        duration = None if self.duration is None else float(self.duration)
        lockstep = self.sim and not children
        step, wall_step = clock_step(self.rate) if self.sim else (0.0, CLOCK_TICK)
        t0, k, watched_at = time.monotonic(), 0, -1
        self.clock_cpu = (t0, processes_cpu(children)) if children else None
        epoch_ns = self._epoch_ns() if self.sim else 0
        launcher.cadence = Cadence()  # the watched topics' stamps (--processes: graph.GraphWatch.watch)
        self.dog = Watchdog(len(self.sc.nodes) + 1, self.watchdog_s).start() if self.sim else None
        names = [s.name for s in self.sc.nodes] + ['recorder'] * (self.bag is not None) + [launcher.get_name()]
        foreign = ForeignCheck(launcher, names, None if children else [launcher, *self.nodes], self.sim)
        while self.context.ok():
            if self._interrupted():
                raise KeyboardInterrupt  # a stop signal, taken between two steps
            if (early := ended_early(children)) is not None:
                self.early = early  # named, and the run failed, at its end ([]: a player played its bag)
                return
            if (found := foreign.look()) is not None:
                raise LaunchError(found)
            if children and k % WATCH_EVERY == 0 and k != watched_at:
                watched_at = k
                launcher.watch(self.record_regex)  # topics whose traffic tells when the processes are done
            if not self.sim:
                if duration is not None and time.monotonic() - t0 >= duration:
                    return
                if self._replayed():
                    self.replay_done = True  # the bag has been played: drain its consumers, then stop
                    print('the bag has been played: stopping once the nodes are done', flush=True)
                    return
                self._pump(executor, time.monotonic() + CLOCK_TICK)
                continue
            t = node_time(k, step, duration)
            if children and k and launcher.cadence.holding(epoch_ns + round(t * 1e9), time.monotonic()):
                self._pump(executor, time.monotonic() + wall_step)  # a process is a step behind (pacing.Cadence)
                t0 = time.monotonic() - k * wall_step  # ... and the held time is not made up by a burst
                continue
            launcher.publish_clock(epoch_ns + round(t * 1e9))
            self.dog.stepped(t)  # sim: the watchdog runs
            if lockstep:
                self._run_until_idle(executor)
            # Never faster than R x real time: wait for the wall time of the next step.
            self._pump(executor, t0 + (k + 1) * wall_step)
            if duration is not None and t >= duration:
                return
            k += 1


def main(argv: list[str] | None = None) -> int:
    args = _parse(argv)
    os.environ.setdefault('AMENT_PREFIX_PATH', sys.prefix)
    launch = None
    try:
        scenario = load_scenario(args.scenario)
        launch = Launch(scenario, args)
        print(f'scenario {scenario.name}: {", ".join(s.name for s in scenario.nodes)}'
              f' ({"processes" if args.processes else "one process"}, '
              f'{f"/clock at {launch.rate:g}x" if launch.sim else "wall time"}'
              f'{f", {launch.duration:g} s" if launch.duration else ""})', flush=True)
        code = launch.run(args.processes, args.hosts)
    except (ScenarioError, LaunchError) as exc:
        print(f'track_nodes.launch: {exc}', file=sys.stderr)
        if launch is not None and launch.bag is not None and not launch.started:
            # refused before it started: its bag holds nothing of the run (at most another graph's traffic)
            shutil.rmtree(launch.bag, ignore_errors=True)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        code = 0
    if launch.dog is not None and launch.dog.stalled:
        code = 1  # its one line is printed already
    if launch.bag is not None and (launch.bag / 'metadata.yaml').exists():
        from track_nodes.report.summary import print_summary

        print_summary(launch.bag, scenario.options.get('summary'))
    return code


if __name__ == '__main__':
    raise SystemExit(main())

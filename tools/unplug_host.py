"""Unplug one simulated host mid-track (issue 15, part 1): an experiment, not a test.

Runs ``python -m track_nodes.launch SCENARIO --processes --hosts 3 --record NAME --rate R`` (as root),
and AT wall seconds after the first leader starts, sets host H's port on the bridge down for
GAP seconds, then up again. Then it reads the bag and reports (and with ``--json FILE`` writes):

- ``gap_steps``: the tracker steps whose truth was published while the host was unplugged (wall
  time after the first leader × rate / Δt; the first leader starts at step 0);
- error against the truth per step (the worst estimate of a step: a parallel chain's too):
  RTAMS (root of the mean squared error) and max, ``before``, ``during`` the gap steps and ``after``;
  ``error_kept_chain``: the same without the estimates of void leads (an estimate is matched to its
  leader's ``step`` event by its spread, the trace of its covariance);
- ``chains``: per step, the leaders that led it (``step`` events minus ``void`` events, the chain
  rule of ``track_core.idsq.leader_protocol``); ``max_chains_after`` over the steps after the gap and
  ``chains_at_end`` over the last ``--end-steps`` recorded steps (1 = converged to one chain);
  ``duplicated_steps``: steps led by more than one sensor (a void lead included);
- ``steps_lost``: steps up to the last recorded estimate with no estimate in the bag (the recorder
  is in the launcher's namespace: an estimate published on the unplugged host beyond the DDS lease
  is not delivered to it, whether or not the track went on there);
- the hosts of the sensors (round robin: node k of the scenario on host k mod 3), the leaders on the
  unplugged host, re-selections, revokes/voids, and the launcher's exit code.

    .venv/bin/python tools/unplug_host.py [--scenario config/idsq.yaml] [--host 1] [--at 8] [--gap 5]
        [--rate 0.5] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import time
from collections import defaultdict
from pathlib import Path

import numpy as np
from watched_launch import WatchedLaunch


def analyse(bag: Path, gap_steps: tuple[int, int], host_of: dict[int, int], host: int, end_steps: int) -> dict:
    """The figures of the module docstring from the recorded bag."""
    from track_core.idsq.leader_protocol import step_of_stamp
    from track_msgs_py.odometry import odometry_to_cv_state
    from track_msgs_py.records.idsq import IdsqLeaderEvent
    from track_msgs_py.stamps import stamp_to_sec
    from track_msgs_py.topics import IDSQ_ESTIMATE, IDSQ_LAYOUT, IDSQ_LEADER, IDSQ_TRUTH
    from track_nodes.report.read import read_topics

    msgs = read_topics(bag, {IDSQ_TRUTH, IDSQ_ESTIMATE, IDSQ_LEADER, IDSQ_LAYOUT})
    # the last layout is the stamped one (the first may be stamped 0, "origin pending")
    origin = stamp_to_sec(msgs[IDSQ_LAYOUT][-1].header.stamp) if msgs.get(IDSQ_LAYOUT) else 0.0
    dt = 0.5
    truth = {}
    for m in msgs.get(IDSQ_TRUTH, []):
        s = step_of_stamp(stamp_to_sec(m.header.stamp), dt, origin)
        truth[s] = odometry_to_cv_state(m)[1][[0, 2]]
    est = defaultdict(list)  # step → [(xy, trace of the xy covariance)]
    for m in msgs.get(IDSQ_ESTIMATE, []):
        s = step_of_stamp(stamp_to_sec(m.header.stamp), dt, origin)
        est[s].append((odometry_to_cv_state(m)[1][[0, 2]], m.pose.covariance[0] + m.pose.covariance[7]))
    events = [IdsqLeaderEvent.from_msg(m) for m in msgs.get(IDSQ_LEADER, [])]
    led, void, spread = defaultdict(set), defaultdict(set), defaultdict(list)
    for e in events:
        if e.event in ('step', 'void'):
            (led if e.event == 'step' else void)[e.step].add(e.leader)
        if e.event == 'step':
            spread[e.step].append((e.leader, e.spread_m2))
    last = max(est) if est else -1

    def kept(s: int, tr: float) -> bool:
        """Is the estimate of step s with spread tr from a leader whose lead was not voided? (Matched
        to the step event of that step with the nearest spread = trace of the covariance.)"""
        if not spread[s]:
            return True
        leader = min(spread[s], key=lambda ls: abs(ls[1] - tr))[0]
        return leader not in void.get(s, set())

    err_all = {s: max(float(np.hypot(*(x - truth[s]))) for x, _ in xs) for s, xs in est.items() if s in truth}
    err_kept = {s: max(e) for s, xs in est.items() if s in truth
                and (e := [float(np.hypot(*(x - truth[s]))) for x, tr in xs if kept(s, tr)])}
    g0, g1 = gap_steps

    def stats(lo: int, hi: int, err: dict) -> dict:
        e = np.array([err[s] for s in range(lo, hi + 1) if s in err])
        return {'steps': [lo, hi], 'n': int(e.size), 'rtams_m': round(float(np.sqrt(np.mean(e ** 2))), 2) if e.size
                else None, 'max_m': round(float(e.max()), 2) if e.size else None}

    live = {s: led[s] - void.get(s, set()) for s in led}
    after = [s for s in live if s > g1]
    tail = sorted(live)[-end_steps:]
    return {
        'gap_steps': [g0, g1], 'last_step_recorded': last, 'truth_steps': len(truth),
        'error': {'before': stats(0, g0 - 1, err_all), 'during': stats(g0, g1, err_all),
                  'after': stats(g1 + 1, last, err_all), 'all': stats(0, last, err_all)},
        'error_kept_chain': {'during': stats(g0, g1, err_kept), 'after': stats(g1 + 1, last, err_kept),
                             'all': stats(0, last, err_kept)},
        'steps_lost': [s for s in range(last + 1) if s not in est],
        'duplicated_steps': sorted(s for s in led if len(led[s]) > 1),
        'max_chains_after': max((len(live[s]) for s in after), default=0),
        'chains_at_end': max((len(live[s]) for s in tail), default=0),
        'chains_per_step': {int(s): sorted(live[s]) for s in sorted(live) if len(led[s]) > 1 or void.get(s)},
        'leaders_on_unplugged_host': sorted({k for s in led for k in led[s] if host_of.get(k) == host}),
        'unplugged_host_led_after_gap': sorted({k for s in after for k in live[s] if host_of.get(k) == host}),
        'reselections': sum(e.event == 'reselect' for e in events),
        'voids': sum(e.event == 'void' for e in events),
    }


def node_hosts(scenario: Path, n_hosts: int) -> dict[int, int]:
    """Sensor id → host, as the launcher spreads the scenario's nodes (round robin, in order)."""
    import yaml

    nodes = yaml.safe_load(scenario.read_text())['track_launch']['ros__parameters']['nodes']
    out = {}
    for i, spec in enumerate(nodes):
        if m := re.search(r':sensor_(\d+)$', spec):
            out[int(m.group(1))] = i % n_hosts
    return out


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument('--scenario', default='config/idsq.yaml')
    ap.add_argument('--host', type=int, default=1)
    ap.add_argument('--at', type=float, default=8.0, help='wall seconds after the first leader starts')
    ap.add_argument('--gap', type=float, default=5.0, help='wall seconds unplugged')
    ap.add_argument('--rate', type=float, default=0.5)
    ap.add_argument('--end-steps', type=int, default=10, help='chains_at_end: over this many last steps')
    ap.add_argument('--record', default=f'unplug-{int(time.time())}')
    ap.add_argument('--json', type=Path, help='write the figures here')
    ap.add_argument('--python', default=sys.executable, help='the interpreter of the launcher (another checkout)')
    args = ap.parse_args()
    scenario = Path(args.scenario).resolve()
    cmd = [args.python, '-m', 'track_nodes.launch', str(scenario), '--processes',
           '--hosts', '3', '--record', args.record, '--rate', str(args.rate)]
    run = WatchedLaunch(cmd)
    if not run.started.wait(180) or not run.tag:
        run.stop()
        print(''.join(run.out[-20:]), ''.join(run.err[-20:]))
        return 1
    t0 = time.monotonic()
    time.sleep(args.at)
    port = ['ip', '-n', f'{run.tag}-hub', 'link', 'set', f'{run.tag}b{args.host}']
    subprocess.run([*port, 'down'], check=True)
    down = time.monotonic() - t0
    time.sleep(args.gap)
    subprocess.run([*port, 'up'], check=True)
    up = time.monotonic() - t0
    code = run.wait()
    report(args, scenario, run.out, run.err, down, up, code)
    return code


def report(args, scenario: Path, out: list[str], err: list[str], down: float, up: float, code: int) -> None:
    """Print the run and its figures; the launcher's whole output goes to RECORD.log."""
    Path(f'{args.record}.log').write_text(''.join(out) + ''.join(err))
    print(f'host {args.host} unplugged at {down:.2f} s, plugged back at {up:.2f} s (wall, after the first leader)')
    print(''.join(line for line in out if 'recording /' not in line))
    warn = [line for line in err if 'WARN' in line or 'ERROR' in line]
    print(''.join(warn)[-3000:])
    dt = 0.5
    gap = (int(down * args.rate / dt), int(np.ceil(up * args.rate / dt)))
    res = {'host': args.host, 'gap_s': args.gap, 'at_s': args.at, 'rate': args.rate,
           'down_s': round(down, 2), 'up_s': round(up, 2), 'launcher_exit': code,
           'revokes_logged': sum('revok' in line and 'revoked its handoff' not in line for line in err),
           'expired_logged': sum('expired:' in line for line in err),
           **analyse(Path('bags') / args.record, gap, node_hosts(scenario, 3), args.host, args.end_steps)}
    print(json.dumps(res, indent=1))
    if args.json:
        args.json.write_text(json.dumps(res, indent=1) + '\n')


if __name__ == '__main__':
    raise SystemExit(main())

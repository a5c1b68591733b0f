"""The soak's ``long`` part: the maritime scenario for an hour of data, in one process and with ``--processes``.

Each run is ``python -m track_nodes.launch maritime --duration D --rate R`` ending by its own
duration. Beside it the soak samples every process's RSS and CPU (``growth``) and counts the
estimator outputs (``probe``). The goals, per run: every process's RSS grows by less than
``MAX_SLOPE`` MiB per data hour after the warm-up, and the outputs per wall second of the last
quarter of data time are at least ``MIN_PACE_RATIO`` of the first quarter's, each output topic's
count among them too (the quarters are of equal data time: a topic that thinned out or died, an
IDSQ chain lost, fails the run even when the clock went faster).
"""

from __future__ import annotations

import contextlib
import time
from pathlib import Path

from track_experiments.soak.growth import WARMUP_SHARE, Series, quarters, sample
from track_experiments.soak.probe import OutputProbe
from track_experiments.soak.procs import Proc, launch_cmd

SCENARIO = 'maritime'
MODES = {'in-process': (), 'processes': ('--processes',)}
MAX_SLOPE = 5.0  # [MiB per data hour] goal: the RSS growth of every process after the warm-up
MIN_PACE_RATIO = 0.9  # goal: outputs per wall s in the last quarter / in the first
SAMPLE_EVERY = 2.0  # [wall s] between two RSS samples
SLOWDOWN = 40.0  # a run still going after this many times its nominal wall time (D / R) is stopped


def long_runs(out: Path, env: dict[str, str], duration: float, rate: float, timeout: float,
              modes: tuple[str, ...] = tuple(MODES)) -> list[dict]:
    """One dict per mode: exit, wall s, quarters, per-process RSS slopes and whether the goals were met."""
    from track_nodes.launch.isolation import free_domain

    held = None
    if not env.get('ROS_DOMAIN_ID'):  # the probe must know the run's domain
        domain, held = free_domain()
        env = {**env, 'ROS_DOMAIN_ID': str(domain)}
    runs: list[dict] = []
    try:
        for mode in modes:
            runs.append(_run(out, env, mode, duration, rate, timeout))
            if runs[-1]['interrupted']:
                break  # Ctrl-C: the figures so far, no further run
        return runs
    finally:
        if held is not None:
            held.close()


def _run(out: Path, env: dict[str, str], mode: str, duration: float, rate: float, timeout: float) -> dict:
    cmd = launch_cmd(SCENARIO, '--duration', f'{duration:g}', '--rate', f'{rate:g}', *MODES[mode])
    series: dict[int, Series] = {}
    warmup = WARMUP_SHARE * duration
    interrupted = False
    with OutputProbe(int(env['ROS_DOMAIN_ID'])) as probe:
        proc = Proc(f'long-{mode}', cmd, out / f'long-{mode}.log', env)
        t0 = time.monotonic()
        deadline = t0 + timeout + SLOWDOWN * duration / rate
        try:
            while proc.popen.poll() is None and time.monotonic() < deadline:
                sample(proc.popen.pid, probe.data_s, series, 'launcher' if MODES[mode] else 'launcher (every node)')
                probe.spin(SAMPLE_EVERY)
        except KeyboardInterrupt:  # an hour is long: Ctrl-C stops the run and still reports what it measured
            interrupted = True
        finally:
            with contextlib.suppress(Exception):
                probe.spin(0.5)  # the last outputs in flight
            timed_out = proc.popen.poll() is None
            proc.terminate()
    wall = time.monotonic() - t0
    quarter = quarters(probe.clock, probe.outputs, probe.epoch_ns, duration)
    procs = sorted(({'process': s.label, 'rss_start': _rss_at(s, warmup), 'rss_end': s.samples[-1][1],
                     'slope': s.slope(warmup), 'cpu_s': s.samples[-1][2] - s.samples[0][2]}
                    for s in series.values() if s.samples), key=lambda p: -(p['slope'] or 0.0))
    ratio, thinned = None, []
    if len(quarter) == 4 and quarter[0]['per_wall_s'] and quarter[3]['per_wall_s'] is not None:
        ratio = quarter[3]['per_wall_s'] / quarter[0]['per_wall_s']
        first, last = quarter[0]['by_topic'], quarter[3]['by_topic']
        thinned = [t for t in first if last[t] < MIN_PACE_RATIO * first[t]]
    worst = max((p['slope'] for p in procs if p['slope'] is not None), default=None)
    problems = []
    if interrupted:
        problems.append(f'interrupted at {probe.data_s:.0f} data s')
    elif proc.popen.returncode != 0:
        problems.append(f'exit {proc.popen.returncode}' + (' (stopped: too slow)' if timed_out else '')
                        + f' [{proc.tail(1)[:160]}]')
    if len(quarter) < 4:
        problems.append(f'the clock reached {probe.data_s:.0f} of {duration:g} data s')
    return {'mode': mode, 'exit': proc.popen.returncode, 'wall_s': wall, 'data_s': probe.data_s,
            'outputs': sum(len(v) for v in probe.outputs.values()), 'quarters': quarter, 'pace_ratio': ratio,
            'thinned': thinned, 'interrupted': interrupted, 'worst_slope': worst, 'processes': procs,
            'problem': '; '.join(problems),
            'goals_met': not problems and worst is not None and worst < MAX_SLOPE
            and ratio is not None and ratio >= MIN_PACE_RATIO and not thinned}


def _rss_at(s: Series, data_s: float) -> float:
    """The first RSS sampled at or after ``data_s`` (the last one if none)."""
    return next((r for t, r, _ in s.samples if t >= data_s), s.samples[-1][1])


def format_runs(runs: list[dict], shown: int = 5) -> str:
    """The long runs' table: per run its pace and the RSS slopes of its ``shown`` fastest-growing processes."""
    from track_experiments.cli import format_table

    head = ['run', 'process', 'RSS MiB (after warm-up → end)', 'slope MiB/data h', 'CPU s',
            'outputs/wall s q1 → q4', 'ratio', 'data pace q1 → q4', 'goals']
    lines = []
    for r in runs:
        q = r['quarters']
        rate = f'{q[0]["per_wall_s"]:.2f} → {q[-1]["per_wall_s"]:.2f}' if len(q) == 4 else '-'
        pace = f'{q[0]["pace"]:.2f} → {q[-1]["pace"]:.2f}' if len(q) == 4 else '-'
        ratio = '-' if r['pace_ratio'] is None else f'{r["pace_ratio"]:.2f}'
        over = sum(1 for p in r['processes'] if p['slope'] is not None and p['slope'] >= MAX_SLOPE)
        goals = 'met' if r['goals_met'] else f'NOT met ({over} of {len(r["processes"])} over {MAX_SLOPE:g}' + (
            f'; thinned out: {", ".join(r["thinned"])})' if r['thinned'] else ')')
        for k, p in enumerate(r['processes'][:shown]):
            first = k == 0
            lines.append([r['mode'] if first else '', p['process'], f'{p["rss_start"]:.1f} → {p["rss_end"]:.1f}',
                          '-' if p['slope'] is None else f'{p["slope"]:.1f}', f'{p["cpu_s"]:.0f}',
                          rate if first else '', ratio if first else '', pace if first else '', goals if first else ''])
        if len(r['processes']) > shown:
            lines.append(['', f'... {len(r["processes"]) - shown} more', '', '', '', '', '', '', ''])
    return (format_table(head, lines) + f'\nslope: least squares after the first {WARMUP_SHARE:.0%} of data time; '
            f'goals: every slope < {MAX_SLOPE:g} MiB/data h, last-quarter outputs per wall s (and of each output '
            f'topic) >= {MIN_PACE_RATIO:.0%} of the first quarter\'s')

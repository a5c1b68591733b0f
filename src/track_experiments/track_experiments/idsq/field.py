"""``track-experiment idsq-field``: the IDSQ sensor field with one process per sensor over simulated hosts.

For each field size K (full: 24, 64, 100; quick: 8, 16) the launcher runs ``idsq_yaml(seed, K)``
with ``--processes --hosts H --record`` (H = ceil(K / ``per_host``), at least 2: 3, 7 and 10 hosts
at 10 sensors a host), so every sensor node is its own process in one of H network namespaces,
discovering through the launcher's discovery server (``track_nodes.launch.hosts``). Per run:

- **bit for bit**: the recorded ``/idsq/estimate`` must be one estimate per step 0..T-1 whose means
  and covariances equal exactly the core's ``protocol_track`` (what the in-process network
  publishes: the integration tests check that equality for K = 8 and 24);
- **bring-up**: wall seconds from the launcher's start until every node announced itself, the
  recorder subscribed to every topic and every /clock subscription matched (its ``ready:`` line);
- **CPU per step**: the CPU time of every process of the run (all threads, the launcher's too)
  from the clock's start until the work of the last step is done (the launcher's ``cpu:`` line),
  over T steps. Bring-up and teardown are excluded by construction (the launcher reads the CPU
  when its clock starts and when the last message has come), so one run per size suffices.

The fit is least squares of CPU per step on K (a + b·K) and the log-log slope between the
smallest and the largest field. The machine's other load counts in the wall times (bring-up) but
hardly in the CPU times, which are the field's own.

Needs root and ``ip netns`` (``track_nodes.launch.hosts.unavailable``); elsewhere one line, exit 2.
"""

from __future__ import annotations

import math
import os
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np

from track_core.idsq.config import LeaderConfig
from track_core.idsq.leader_protocol import protocol_track
from track_experiments.cli import Outcome, RunConfig, format_table, set_keys
from track_experiments.plotting import pyplot
from track_experiments.soak.procs import Proc, launch_cmd

FULL_SIZES, QUICK_SIZES = (24, 64, 100), (8, 16)
FULL_STEPS, QUICK_STEPS = 40, 10
PER_HOST = 10  # sensors per simulated host
DT = LeaderConfig().tracker.dt  # [s] the tracker step of idsq_yaml's scenario (the sensors' default)
READY = re.compile(r'^ready: (\d+) nodes in ([\d.]+) s', re.M)
CPU = re.compile(r'^cpu: ([\d.]+) s in (\d+) processes', re.M)
HOSTS_LINE = re.compile(r'hosts: \d+ namespaces (\S+)-\*')


def _sizes(cfg: RunConfig) -> list[int]:
    text = cfg.options.get('sensors')
    if text is None:
        return list(QUICK_SIZES if cfg.quick else FULL_SIZES)
    try:
        sizes = [int(v) for v in text.split(',')]
    except ValueError:
        raise ValueError(f'--set sensors={text}: must be comma-separated integers') from None
    if not sizes or any(k < 8 or k % 4 for k in sizes):
        raise ValueError(f'--set sensors={text}: every field needs a multiple of 4 sensors, at least 8')
    return sizes


def _int_option(cfg: RunConfig, key: str, default: int, lo: int) -> int:
    text = cfg.options.get(key)
    if text is None:
        return default
    try:
        value = int(text)
    except ValueError:
        raise ValueError(f'--set {key}={text}: must be an integer') from None
    if value < lo:
        raise ValueError(f'--set {key}={text}: must be >= {lo}')
    return value


def hosts_for(k: int, per_host: int = PER_HOST) -> int:
    """Simulated hosts for a field of ``k`` sensors: ceil(k / per_host), at least 2."""
    return max(2, math.ceil(k / per_host))


def run_field(out: Path, seed: int, k: int, n_hosts: int, steps: int) -> dict:
    """One recorded run of a ``k``-sensor field over ``n_hosts`` hosts; its row (see the module docstring)."""
    from track_nodes.idsq.scenario_files import idsq_yaml
    from track_nodes.launch.hosts import remove_leftovers
    from track_nodes.report.idsq import recorded_track

    scenario = out / f'field-{k}.yaml'
    scenario.write_text(idsq_yaml(seed=seed, n_sensors=k, duration=steps * DT))
    bag = out / 'bags' / f'field-{k}'
    shutil.rmtree(bag, ignore_errors=True)
    env = {**os.environ, 'PYTHONUNBUFFERED': '1'}
    # the launcher's own deadlines: ready in 60 s + 4 s a process; then the run and the stop
    timeout = 60 + 4 * (k + 2) + steps * DT + 300
    proc = Proc(f'field-{k}', launch_cmd(str(scenario), '--processes', '--hosts', str(n_hosts),
                                         '--duration', str(steps * DT), '--record', f'field-{k}'),
                out / f'field-{k}.log', env, cwd=out)
    try:
        code = proc.popen.wait(timeout=timeout)
    except subprocess.TimeoutExpired:
        code = proc.terminate()  # SIGTERM: the launcher stops its children and removes the hosts
    text = proc.text()
    tag = HOSTS_LINE.search(text)
    left = remove_leftovers(tag.group(1)) if tag else []
    ready, cpu = READY.search(text), CPU.search(text)
    row = {'sensors': k, 'hosts': n_hosts, 'processes': k + 2, 'steps': steps, 'exit': code,
           'ready_s': float(ready.group(2)) if ready else None, 'cpu_s': float(cpu.group(1)) if cpu else None,
           'cpu_per_step_s': float(cpu.group(1)) / steps if cpu else None,
           'dds_teardown_alarms': text.count('its DDS teardown'), 'namespaces_left': left,
           'estimates': 0, 'bit_for_bit': False, 'max_abs_diff': None, 'problem': ''}
    ref_means, ref_covs, _ = protocol_track(seed, k, steps)
    try:
        got_steps, means, covs = recorded_track(bag, DT)
    except (OSError, ValueError) as exc:
        row['problem'] = f'no track recorded ({exc}); log: {_last_line(text)}'
        return row
    row['estimates'] = len(got_steps)
    if got_steps != list(range(steps)):
        row['problem'] = f'steps recorded {got_steps}, wanted 0..{steps - 1}'
    else:
        diff = max(float(np.abs(means - ref_means).max()), float(np.abs(covs - ref_covs).max()))
        row['max_abs_diff'] = diff
        row['bit_for_bit'] = bool(np.array_equal(means, ref_means) and np.array_equal(covs, ref_covs))
        if not row['bit_for_bit']:
            row['problem'] = f'track differs from the in-process one (max abs diff {diff:g})'
    if code != 0 and not row['problem']:
        row['problem'] = f'launcher exit {code}: {_last_line(text)}'
    if row['cpu_s'] is None and not row['problem']:
        row['problem'] = 'no cpu line from the launcher'
    if left:
        row['problem'] += f'; namespaces left behind: {left}'
    return row


def _last_line(text: str, width: int = 300) -> str:
    """The log's last line that says something (the launcher's reason, usually), cut to ``width``."""
    lines = [ln for ln in text.splitlines() if ln.strip() and 'recorder]: record' not in ln]
    return (lines[-1] if lines else '(no output)')[:width]


def fit(rows: list[dict]) -> dict:
    """Least squares CPU per step = a + b·K over the rows that have it, and the log-log slope end to end."""
    pts = [(r['sensors'], r['cpu_per_step_s']) for r in rows if r['cpu_per_step_s']]
    if len(pts) < 2:
        return {'intercept_s': None, 'per_sensor_s': None, 'loglog_slope': None, 'sensors': []}
    k, c = np.array(pts, dtype=float).T
    b, a = np.polyfit(k, c, 1)
    slope = float(np.log(c[-1] / c[0]) / np.log(k[-1] / k[0])) if k[-1] != k[0] else None
    return {'intercept_s': float(a), 'per_sensor_s': float(b), 'loglog_slope': slope,
            'sensors': [int(v) for v in k]}


@set_keys(sensors='field sizes, comma-separated (full: 24,64,100; quick: 8,16)',
          steps=f'tracker steps per run (full: {FULL_STEPS}, quick: {QUICK_STEPS})',
          per_host=f'sensors per simulated host (default {PER_HOST}; at least 2 hosts)')
def field(cfg: RunConfig) -> Outcome:
    from track_nodes.launch.hosts import unavailable

    sizes = _sizes(cfg)
    steps = _int_option(cfg, 'steps', QUICK_STEPS if cfg.quick else FULL_STEPS, 2)
    per_host = _int_option(cfg, 'per_host', PER_HOST, 1)
    if (reason := unavailable()) is not None:
        raise ValueError(f'needs simulated hosts: {reason}')
    cfg.out.mkdir(parents=True, exist_ok=True)
    rows = [run_field(cfg.out.resolve(), cfg.seed, k, hosts_for(k, per_host), steps)
            for k in cfg.progress(sizes, desc='idsq-field')]
    f = fit(rows)
    table = format_table(
        ['sensors', 'hosts', 'processes', 'ready s', 'CPU s', 'CPU s/step', 'estimates', 'bit for bit', 'problem'],
        [[r['sensors'], r['hosts'], r['processes'], r['ready_s'], r['cpu_s'], r['cpu_per_step_s'], r['estimates'],
          'yes' if r['bit_for_bit'] else 'NO', r['problem'] or '-'] for r in rows])
    if f['per_sensor_s'] is not None:
        table += (f'\nCPU per step = {f["intercept_s"]:.4f} s + {f["per_sensor_s"]:.5f} s x sensors '
                  f'(least squares over K = {", ".join(map(str, f["sensors"]))}); log-log slope '
                  f'{f["sensors"][0]}..{f["sensors"][-1]}: {f["loglog_slope"]:.2f}')
    table += (f'\n{steps} steps of {DT} s per run, seed {cfg.seed}, one process per sensor; CPU of every '
              'process of the run from the clock\'s start to the end of the work.')
    figs = [_figure(cfg.out / 'idsq-field-cpu.png', rows, f)] if f['per_sensor_s'] is not None else []
    return Outcome(table, {'rows': rows, 'fit': f, 'all_bit_for_bit': all(r['bit_for_bit'] for r in rows)}, figs)


def _figure(path: Path, rows: list[dict], f: dict) -> Path:
    plt = pyplot()
    pts = [(r['sensors'], r['cpu_per_step_s']) for r in rows if r['cpu_per_step_s']]
    k, c = np.array(pts, dtype=float).T
    fig, ax = plt.subplots(figsize=(5, 3.5), constrained_layout=True)
    ax.plot(k, c, 'o', label='measured')
    ks = np.linspace(0, k.max() * 1.05, 50)
    ax.plot(ks, f['intercept_s'] + f['per_sensor_s'] * ks, '-',
            label=f'{f["intercept_s"]:.3f} + {f["per_sensor_s"]:.4f} K')
    ax.set_xlabel('sensors K (one process each)')
    ax.set_ylabel('CPU s per tracker step')
    ax.set_title('IDSQ field over simulated hosts')
    ax.legend()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path

"""``track-experiment soak`` (see the package docstring).

Options (``--set KEY=VALUE``): ``busy`` CPU-bound processes beside the soak (default 0);
``loops`` of the bag (default 5; ``--quick`` 3); ``sensors`` of the bring-up field (default 100;
``--quick`` 24); ``run`` wall seconds each concurrent run and the field run before SIGTERM (default
20; ``--quick`` 6); ``timeout`` wall seconds for any process to come up (default 300);
``parts`` a comma list of ``concurrent``, ``loop``, ``bringup`` (default these three) and ``long``
(the maritime scenario for ``data`` seconds of data, default 3600, ``--quick`` 300, at ``rate``,
default 20, in one process and with ``--processes``, or those of ``modes``: see ``long``); ``domain`` the
ROS_DOMAIN_ID of the loop and bring-up processes (default: the environment's). The concurrent
runs always get the environment as it is, as three runs a user starts would.
Bags and logs go to ``--out``/soak-<time>/. The outcome's ``survived`` is true when every row did.
"""

from __future__ import annotations

import dataclasses
import time
from datetime import datetime

from track_experiments.cli import Outcome, RunConfig, format_table, set_keys
from track_experiments.soak import long, parts
from track_experiments.soak.procs import busy_loops

PARTS = ('concurrent', 'loop', 'bringup')  # the default; ``long`` takes an hour or more
ALL_PARTS = (*PARTS, 'long')


def _option_number(cfg: RunConfig, key: str, full: float, quick: float, lo: float, kind=int):
    text = cfg.options.get(key)
    if text is None:
        return kind(quick if cfg.quick else full)
    try:
        value = kind(text)
    except ValueError:
        raise ValueError(f'--set {key}={text}: not a number') from None
    if not value >= lo:
        raise ValueError(f'--set {key}={text}: must be >= {lo:g}')
    return value


@set_keys(busy='CPU-bound processes beside the soak (0)', loops='times the bag is played (5; --quick: 3)',
          sensors='nodes of the bring-up field (100; --quick: 24)',
          run='wall s a concurrent or field run lasts before SIGTERM (20; --quick: 6)',
          timeout='wall s for any process to come up (300)',
          parts='comma list of concurrent, loop, bringup (these three), long',
          data='data s of each long run (3600; --quick: 300)', rate='clock rate of the long runs (20)',
          modes='comma list of the long runs: in-process, processes (both)',
          domain='ROS_DOMAIN_ID of the loop and bring-up processes (the environment\'s)')
def soak_experiment(cfg: RunConfig) -> Outcome:
    busy = _option_number(cfg, 'busy', 0, 0, 0)
    loops = _option_number(cfg, 'loops', 5, 3, 1)
    sensors = _option_number(cfg, 'sensors', 100, 24, 2)
    run_s = _option_number(cfg, 'run', 20.0, 6.0, 0.0, float)
    timeout = _option_number(cfg, 'timeout', 300.0, 300.0, 1.0, float)
    chosen = [p.strip() for p in cfg.options.get('parts', ','.join(PARTS)).split(',') if p.strip()]
    if unknown := [p for p in chosen if p not in ALL_PARTS]:
        raise ValueError(f'--set parts: unknown {", ".join(unknown)}; choose from {", ".join(ALL_PARTS)}')
    data_s = _option_number(cfg, 'data', 3600.0, 300.0, 1.0, float)
    rate = _option_number(cfg, 'rate', 20.0, 20.0, 0.01, float)
    modes = tuple(m.strip() for m in cfg.options.get('modes', ','.join(long.MODES)).split(',') if m.strip())
    bad = [m for m in modes if m not in long.MODES]
    if bad or not modes:
        raise ValueError(f'--set modes: {", ".join(bad) or "none"}; choose from {", ".join(long.MODES)}')
    out = cfg.out / f'soak-{datetime.now():%Y%m%d-%H%M%S}'
    out.mkdir(parents=True, exist_ok=False)
    env = parts.soak_env(cfg.options.get('domain'))
    rows: list[parts.Row] = []
    runs: list[dict] = []
    took: dict[str, float] = {}
    with busy_loops(busy):
        for part in cfg.progress(chosen, desc='soak', unit='part'):
            t0 = time.monotonic()
            if part == 'concurrent':
                rows += parts.concurrent(out, parts.soak_env(None), run_s, timeout)
            elif part == 'long':
                runs = long.long_runs(out, env, data_s, rate, timeout, modes)
                rows += [parts.Row('long', r['mode'], r['exit'], messages=r['outputs'], problem=r['problem'])
                         for r in runs]
            elif part == 'loop':
                rows += parts.loop(out, env, loops, timeout)
            else:
                rows += parts.bringup(out, env, sensors, run_s, timeout)
            took[part] = time.monotonic() - t0
    header = ['part', 'run', 'exit', 'up s', 'stop s', 'messages', 'lost', 'survived', 'problem']
    table = format_table(header, [[r.part, r.run, r.exit, _s(r.ready_s), _s(r.stop_s), r.messages,
                                   '-' if r.lost is None else r.lost, 'yes' if r.survived else 'NO',
                                   r.problem or '-'] for r in rows])
    if runs:
        table += '\n\n' + long.format_runs(runs)
    table += '\n' + ', '.join(f'{p} {s:.0f} s' for p, s in took.items()) + f' (busy loops beside: {busy}; {out})'
    data = {'survived': all(r.survived for r in rows), 'busy': busy, 'out': str(out), 'seconds': took,
            'rows': [dataclasses.asdict(r) for r in rows], 'long': runs}
    return Outcome(table, data)


def _s(v: float | None) -> str:
    return '-' if v is None else f'{v:.1f}'

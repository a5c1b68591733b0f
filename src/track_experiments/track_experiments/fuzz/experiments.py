"""``track-experiment fuzz``: the long mode of the fuzzer, a table row per node configuration.

Options (``--set KEY=VALUE``): ``node`` = a case of ``table.cases()`` or ``all`` (default ``all``),
``messages`` = bad messages per case (default 10000; ``--quick``: 300). ``--seed`` seeds the
generator. Each case runs on its own ROS domain (``ROS_DOMAIN_ID``, default 0, plus the case's
index, modulo 233, the largest id Fast DDS accepts + 1), localhost-only discovery.
"""

from __future__ import annotations

import os

from track_experiments.cli import Outcome, RunConfig, format_table, set_keys
from track_experiments.fuzz.harness import run_case
from track_experiments.fuzz.table import cases

QUICK_MESSAGES = 300


@set_keys(node='a case of table.cases() or all (all)', messages='bad messages per case (10000; --quick: 300)')
def fuzz_experiment(cfg: RunConfig) -> Outcome:
    table = cases()
    which = cfg.options.get('node', 'all')
    if which != 'all' and which not in table:
        raise ValueError(f'--set node={which}: not a fuzz case; choose all or one of {", ".join(table)}')
    try:
        messages = int(cfg.options.get('messages', QUICK_MESSAGES if cfg.quick else 10_000))
    except ValueError:
        raise ValueError(f'--set messages={cfg.options["messages"]}: not an integer') from None
    if messages < 1:
        raise ValueError(f'--set messages={messages}: must be >= 1')
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    base = int(os.environ.get('ROS_DOMAIN_ID', '0'))
    names = list(table) if which == 'all' else [which]
    rows, data = [], {}
    for k, name in enumerate(names):
        res = run_case(table[name], messages, seed=cfg.seed, domain_id=(base + k) % 233)
        data[name] = res.summary()
        reasons = ', '.join(f'{key}={n}' for key, n in sorted(res.refusals.items())) or '-'
        rows.append([name, res.sent, res.alive, sum(res.output_after.values()), sum(res.nan_outputs.values()),
                     res.log_lines, res.lines_per_bad, len(res.crashes), reasons])
    header = ['node', 'sent', 'alive', 'output after', 'NaN outputs', 'log lines', 'lines/bad', 'crashes',
              'refusals by reason']
    return Outcome(format_table(header, rows), {'cases': data})

"""``track-experiment`` and ``track-bench``: one runner, two entry-point registries.

Packages register entries in their setup.py under the groups ``track.experiments`` and
``track.benchmarks`` (``name = module:function``). An entry is a function taking a
``RunConfig`` and returning an ``Outcome``; the runner owns argument parsing, the output
directory, the JSON file and error reporting, so entries contain only their science.
Entries are imported lazily, so ``--help`` never imports rclpy (``NAME --help`` imports that entry).

An entry declares the ``--set`` keys it reads once, with ``@set_keys(key='what it sets', ...)``:
the runner refuses any other key in one line with the closest declared ones (exit code 2), and
``track-experiment NAME --options`` (or ``NAME --help``) lists them with their meaning;
``--options`` without a name lists the keys of every entry. An entry without the decorator takes
no ``--set``.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from importlib.metadata import entry_points
from pathlib import Path
from typing import Any

from track_core.names import unknown_line

GROUPS = {'experiment': 'track.experiments', 'bench': 'track.benchmarks'}


@dataclass
class RunConfig:
    """What every experiment or benchmark is given. ``runs=None`` means the entry's default."""

    seed: int = 0
    runs: int | None = None
    quick: bool = False
    out: Path = Path('out')
    show_progress: bool = True
    options: dict[str, str] = field(default_factory=dict)   # --set KEY=VALUE (entry-specific; see its docstring)
    reading: str | None = None  # entry-specific interpretation switch (e.g. sonar-table2 --reading)

    def n_runs(self, full: int, quick: int) -> int:
        """The run count: ``--runs`` if given, else ``quick`` under ``--quick``, else ``full``."""
        if self.runs is not None:
            return self.runs
        return quick if self.quick else full

    def choice(self, key: str, *allowed: str) -> str:
        """Option ``key`` (default: the first of ``allowed``); ``ValueError`` naming them when it is another."""
        value = self.options.get(key, allowed[0])
        if value not in allowed:
            raise ValueError(f'--set {key}={value!r}: allowed {", ".join(allowed[:-1])} or {allowed[-1]}')
        return value

    def progress(self, iterable: Iterable, **kw: Any) -> Iterable:
        """A tqdm progress bar on stderr (silent when show_progress is False)."""
        from tqdm import tqdm

        return tqdm(iterable, disable=not self.show_progress, file=sys.stderr, **kw)


@dataclass
class Outcome:
    """An entry's result: ``table`` is printed, ``data`` goes to ``--json``, ``figures`` are PNGs."""

    table: str
    data: dict[str, Any]
    figures: list[Path] = field(default_factory=list)


def set_keys(**keys: str) -> Callable[[Callable], Callable]:
    """Declare the ``--set`` keys an entry reads (``key='what it sets (default)'``); see the module doc."""
    def mark(fn: Callable) -> Callable:
        fn.set_keys = dict(keys)
        return fn
    return mark


def entry_keys(fn: Callable) -> dict[str, str]:
    """The ``--set`` keys an entry declared (``set_keys``): key → description."""
    return dict(getattr(fn, 'set_keys', {}))


def unknown_keys_problem(fn: Callable, options: dict[str, str]) -> str | None:
    """One line naming the ``--set`` keys that ``fn`` does not declare, or None."""
    unknown = set(options) - set(entry_keys(fn))
    return None if not unknown else unknown_line('--set key' + ('s' if len(unknown) > 1 else ''), unknown,
                                                 entry_keys(fn))


def options_text(name: str, fn: Callable) -> str:
    """The ``--set`` keys of entry ``name`` with their meaning, one per line (``--options``)."""
    keys = entry_keys(fn)
    lines = [f'  {k}: {v}' for k, v in sorted(keys.items())] or ['  (none: this entry takes no --set)']
    return '\n'.join([f'--set keys of {name}:', *lines])


def _keys_help(entries: dict[str, Any], argv: list[str] | None) -> str:
    """For ``NAME --help``: the ``--set`` keys of NAME (importing that entry only)."""
    args = sys.argv[1:] if argv is None else argv
    if not {'-h', '--help'} & set(args):
        return ''
    name = next((a for a in args if not a.startswith('-')), None)
    if name not in entries:
        return ''
    return options_text(name, entries[name].load())


def registry(kind: str) -> dict[str, Any]:
    """Name → entry point for ``kind`` in {'experiment', 'bench'}."""
    return {ep.name: ep for ep in entry_points(group=GROUPS[kind])}


def format_table(header: list[str], rows: list[list[Any]]) -> str:
    """Plain fixed-width table; floats get 4 significant digits."""

    def fmt(v: Any) -> str:
        return f'{v:.4g}' if isinstance(v, float) else str(v)

    cells = [header, *[[fmt(v) for v in r] for r in rows]]
    widths = [max(len(r[i]) for r in cells) for i in range(len(header))]
    lines = ['  '.join(c.rjust(w) for c, w in zip(r, widths, strict=True)) for r in cells]
    lines.insert(1, '  '.join('-' * w for w in widths))
    return '\n'.join(lines)


def best_time(fn: Callable[[], Any], repeat: int = 5, min_time: float = 0.05) -> float:
    """Seconds per call: best of ``repeat`` batches, each looping until ``min_time`` passes."""
    fn()  # warm-up
    best = float('inf')
    for _ in range(repeat):
        n, t0 = 0, time.perf_counter()
        while True:
            fn()
            n += 1
            dt = time.perf_counter() - t0
            if dt >= min_time:
                break
        best = min(best, dt / n)
    return best


def _print_options(prog: str, entries: dict[str, Any], name: str | None) -> int:
    """``--options``: the ``--set`` keys of ``name`` (of every entry when None); exit code."""
    if name is not None and name not in entries:
        print(f'{prog}: unknown entry {name!r}; registered: {", ".join(sorted(entries))}', file=sys.stderr)
        return 2
    print('\n'.join(options_text(n, entries[n].load()) for n in ([name] if name else sorted(entries))))
    return 0


def _key_value(text: str) -> tuple[str, str]:
    key, sep, value = text.partition('=')
    if not sep or not key.strip():
        raise argparse.ArgumentTypeError(f'expected KEY=VALUE, got {text!r}')
    return key.strip(), value


def _main(kind: str, argv: list[str] | None) -> int:
    entries = registry(kind)
    prog = f'track-{kind}'
    parser = argparse.ArgumentParser(
        prog=prog, formatter_class=argparse.RawDescriptionHelpFormatter,
        description=(
            'Reproduce a paper table or figure.' if kind == 'experiment'
            else 'Time our code against a baseline or peer in the same run and report ratios.'
        ),
        epilog='\n\n'.join(x for x in ('registered: ' + (', '.join(sorted(entries)) or '(none)'),
                                         _keys_help(entries, argv)) if x),
    )
    parser.add_argument('name', nargs='?', help='entry to run (see "registered" below)')
    parser.add_argument('--list', action='store_true', help='list registered entries and exit')
    parser.add_argument('--runs', type=int, default=None, help='Monte-Carlo runs / repetitions')
    parser.add_argument('--seed', type=int, default=0, help='seed of the numpy Generator (default 0)')
    parser.add_argument('--quick', action='store_true', help='small, fast version (used by the tests)')
    parser.add_argument('--json', type=Path, default=None, metavar='FILE', help='write the result as JSON')
    parser.add_argument('--out', type=Path, default=Path('out') / kind, help='directory for PNG/JSON output')
    parser.add_argument('--no-progress', action='store_true', help='hide the progress bar')
    parser.add_argument('--set', action='append', default=[], metavar='KEY=VALUE', type=_key_value,
                        help='an entry-specific option (repeatable; NAME --options lists its keys)')
    parser.add_argument('--options', action='store_true',
                        help="list the entry's --set keys with their meaning and exit (every entry's without NAME)")
    parser.add_argument('--reading', default=None, metavar='WORDS',
                        help='interpretation of the paper for entries that have several (e.g. sonar-table2: '
                             'comma-separated variance|std, spectral|excess, full|position, posterior|predicted)')
    args = parser.parse_args(argv)

    if args.options:
        return _print_options(prog, entries, args.name)
    if args.list or not args.name:
        print('\n'.join(sorted(entries)) if entries else '(no entries registered)')
        return 0 if args.list else 2
    problem = (f'unknown entry {args.name!r}; registered: {", ".join(sorted(entries))}' if args.name not in entries
               else f'--runs must be >= 1, got {args.runs}' if args.runs is not None and args.runs < 1 else None)
    if problem is not None:
        print(f'{prog}: {problem}', file=sys.stderr)
        return 2

    options = dict(args.set)
    logging.basicConfig(level=logging.WARNING, format='%(levelname)s %(name)s: %(message)s')
    cfg = RunConfig(seed=args.seed, runs=args.runs, quick=args.quick, out=args.out,
                    show_progress=not args.no_progress, options=options, reading=args.reading)
    try:
        fn = entries[args.name].load()
        if (problem := unknown_keys_problem(fn, options)) is not None:
            raise ValueError(problem)  # before anything runs or is written
        cfg.out.mkdir(parents=True, exist_ok=True)
        outcome: Outcome = fn(cfg)
    except (ValueError, OSError) as exc:
        print(f'{prog} {args.name}: {exc}', file=sys.stderr)
        return 2

    print(outcome.table)
    for fig in outcome.figures:
        print(f'figure: {fig}')
    if args.json is not None:
        payload = {'name': args.name, 'seed': args.seed, 'runs': args.runs, 'quick': args.quick,
                   **({'options': options} if options else {}),
                   **({'reading': args.reading} if args.reading is not None else {}), **outcome.data}
        try:
            args.json.parent.mkdir(parents=True, exist_ok=True)
            args.json.write_text(json.dumps(payload, indent=2, default=float) + '\n')
        except OSError as exc:
            print(f'{prog}: cannot write --json {args.json}: {exc.strerror}', file=sys.stderr)
            return 2
        print(f'json: {args.json}')
    return 0


def experiment_main(argv: list[str] | None = None) -> int:
    return _main('experiment', argv)


def bench_main(argv: list[str] | None = None) -> int:
    return _main('bench', argv)


if __name__ == '__main__':  # pragma: no cover
    sys.exit(experiment_main())

"""List the modules whose docstring is longer than a limit, longest first.

    .venv/bin/python tools/docstring_lengths.py [--root src] [--lines 30] [--allow 5]

A module docstring's length is the number of source lines from its opening to its closing quotes.
Exit 1 when more than ``--allow`` modules are over ``--lines``, else 0. A module docstring says
what the module does, its contract and the paper's equations; measurements belong to
docs/results/*.md beside the command that makes them.
"""

from __future__ import annotations

import argparse
import ast
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def docstring_lines(path: Path) -> int:
    """Source lines of the module docstring of ``path`` (0 without one)."""
    tree = ast.parse(path.read_text(encoding='utf-8'), filename=str(path))
    if not tree.body:
        return 0
    first = tree.body[0]
    if not (isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant)
            and isinstance(first.value.value, str)):
        return 0
    return first.end_lineno - first.lineno + 1


def long_docstrings(root: Path, limit: int) -> list[tuple[int, Path]]:
    """(lines, path) of every ``*.py`` under ``root`` whose module docstring exceeds ``limit`` lines."""
    found = [(docstring_lines(p), p) for p in sorted(root.rglob('*.py'))]
    return sorted(((n, p) for n, p in found if n > limit), key=lambda t: (-t[0], str(t[1])))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--root', type=Path, default=ROOT / 'src', help='tree to scan (default: src/)')
    ap.add_argument('--lines', type=int, default=30, help='longest allowed docstring (default: 30)')
    ap.add_argument('--allow', type=int, default=5, help='modules allowed over the limit (default: 5)')
    args = ap.parse_args(argv)
    over = long_docstrings(args.root, args.lines)
    for n, p in over:
        print(f'{n:4d}  {p.relative_to(args.root) if p.is_relative_to(args.root) else p}')
    print(f'{len(over)} module docstrings over {args.lines} lines (allowed: {args.allow})')
    return 1 if len(over) > args.allow else 0


if __name__ == '__main__':
    sys.exit(main())

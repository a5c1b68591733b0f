"""Unknown names refused in one line with the closest valid ones (``--set`` keys, node parameters,
scenario sections): a typo is a refusal that says what was meant, never a silent default."""

from __future__ import annotations

import difflib
from collections.abc import Iterable


def closest(name: str, valid: Iterable[str], n: int = 3) -> list[str]:
    """Up to ``n`` names of ``valid`` closest to ``name`` (difflib.get_close_matches), best first."""
    return difflib.get_close_matches(name, list(valid), n=n, cutoff=0.6)


def unknown_line(what: str, unknown: Iterable[str], valid: Iterable[str], where: str = '', known: str = 'known') -> str:
    """``unknown <what> 'x' (did you mean y?)<where>; <known>: ...``: every unknown name with its closest
    valid ones, then the valid names (the first 12 and their count when there are more)."""
    valid = sorted(set(valid))
    parts = []
    for name in sorted(unknown):
        near = closest(name, valid)
        parts.append(f'{name!r} (did you mean {" or ".join(near)}?)' if near else repr(name))
    names = ', '.join(valid) if len(valid) <= 12 else f'{", ".join(valid[:12])}, ... ({len(valid)} in all)'
    return f'unknown {what} {", ".join(parts)}{where}; {known}: {names or "none"}'

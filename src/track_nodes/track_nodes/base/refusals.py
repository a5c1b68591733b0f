"""Refused input, counted per reason and logged at most once per reason every few seconds.

Hostile input gets a reason and changes nothing (issue 13): each refusal is counted under
(topic, kind), where the kind is the reason's field (the text before its first ':', e.g.
``pose.covariance``), and a log line is due only when that kind has not been logged for
``throttle`` seconds. The line carries the count, so a flood of 10,000 bad messages costs a
handful of lines, not 10,000. Pure bookkeeping: the node passes the steady time in.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field


def reason_kind(reason: str) -> str:
    """The field a reason names (``'pose.covariance: ...'`` → ``'pose.covariance'``), else its leading words.

    Without a field, the kind is the words before the first one that carries a value (a digit, a
    quote, bytes...), so ``bad handoff magic/version b'\\xa7...'`` from random bytes is one kind,
    not one per payload.
    """
    head, sep, _ = reason.partition(':')
    if sep and head.strip() and ' ' not in head.strip():
        return head.strip()
    words = []
    for word in reason.split():
        bare = word.rstrip(':;,')
        if not re.fullmatch(r"[A-Za-z_./()-]+", bare):
            break
        words.append(bare)
        if bare != word:  # the words before a ':' (or ',') name it
            break
    return ' '.join(words) or reason.strip()[:20]


@dataclass
class RefusalCounter:
    throttle: float = 5.0
    counts: dict[tuple[str, str], int] = field(default_factory=dict)
    _logged: dict[tuple[str, str], tuple[float, int]] = field(default_factory=dict)

    def refuse(self, topic: str, reason: str, now: float) -> str | None:
        """Count one refusal at steady time ``now``; return the log line when one is due, else ``None``."""
        key = (topic, reason_kind(reason))
        n = self.counts[key] = self.counts.get(key, 0) + 1
        last = self._logged.get(key)
        if last is not None and now - last[0] < self.throttle:
            return None
        since = n - (last[1] if last else 0)
        self._logged[key] = (now, n)
        more = f' ({since} since the last line, {n} in all)' if last else ''
        return f'{topic}: refused: {reason}{more}'

    def total(self) -> int:
        return sum(self.counts.values())

    def by_key(self) -> dict[str, int]:
        """``'<topic> <kind>' → count``, the layout published in the node's diagnostics."""
        return {f'{topic} {kind}': n for (topic, kind), n in sorted(self.counts.items())}

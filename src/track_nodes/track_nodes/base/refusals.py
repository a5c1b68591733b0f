"""Refused input, counted per reason; a new reason logged at once, the rest in one line per period.

Hostile input gets a reason and changes nothing: each refusal is counted under
(topic, kind), where the kind is the reason's field (the text before its first ':', e.g.
``pose.covariance``). The first refusal of a kind is logged at once with its whole reason, so an
operator sees every new problem when it starts. Later ones are only counted; at most once per
``throttle`` seconds, one line for the whole node names every kind refused since the previous line,
with its count and its latest reason. A flood of 10,000 bad messages of 20 kinds over a minute
costs about 20 + 12 lines, not 10,000, and the counts are on ``/diagnostics`` all along.
Pure bookkeeping: the node passes the steady time in.
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


SUMMARY_KINDS = 6  # kinds named in one summary line; the rest are counted as "and N more kinds"


@dataclass
class RefusalCounter:
    throttle: float = 5.0
    counts: dict[tuple[str, str], int] = field(default_factory=dict)
    _pending: dict[tuple[str, str], tuple[int, str]] = field(default_factory=dict)  # since the last line
    _last_summary: float | None = None

    def refuse(self, topic: str, reason: str, now: float) -> str | None:
        """Count one refusal at steady time ``now``; return the log line when one is due, else ``None``."""
        key = (topic, reason_kind(reason))
        first = key not in self.counts
        self.counts[key] = self.counts.get(key, 0) + 1
        if first:
            if self._last_summary is None:  # the first summary comes a period after the first line
                self._last_summary = now
            return f'{topic}: refused: {reason} (new kind of refusal; later ones are summed up every ' \
                   f'{self.throttle:g} s)'
        n, _ = self._pending.get(key, (0, ''))
        self._pending[key] = (n + 1, reason)
        return self.flush(now)

    def flush(self, now: float) -> str | None:
        """The summary line of the refusals since the last one, when it is due (else ``None``)."""
        if not self._pending or (self._last_summary is not None and now - self._last_summary < self.throttle):
            return None
        since = '' if self._last_summary is None else f' in the last {now - self._last_summary:.0f} s'
        self._last_summary = now
        items = sorted(self._pending.items(), key=lambda kv: -kv[1][0])
        self._pending = {}
        parts = [f'{topic} {kind} x{n} ({self.counts[(topic, kind)]} in all; latest: {reason})'
                 for (topic, kind), (n, reason) in items[:SUMMARY_KINDS]]
        if len(items) > SUMMARY_KINDS:
            parts.append(f'and {len(items) - SUMMARY_KINDS} more kinds')
        return f'refused{since}: ' + '; '.join(parts)

    def total(self) -> int:
        return sum(self.counts.values())

    def by_key(self) -> dict[str, int]:
        """``'<topic> <kind>' → count``, the layout published in the node's diagnostics."""
        return {f'{topic} {kind}': n for (topic, kind), n in sorted(self.counts.items())}

"""Counting what a recording lost, so nothing is lost without a count.

Two sources, because neither covers every case:

- gaps in the publication sequence numbers (rmw message info) of a topic with exactly one
  publisher: the count is exact (a sequence that restarts, a new publisher, counts nothing);
- the middleware's message-lost events on topics with several publishers, where sequence
  numbers of different writers cannot be told apart (rmw gives no publisher id to rclpy).
"""

from __future__ import annotations

from collections import defaultdict


class LossCounter:
    """Lost messages per topic (pure bookkeeping; the recorder feeds it)."""

    def __init__(self) -> None:
        self.lost: dict[str, int] = defaultdict(int)
        self._single: dict[str, bool] = {}
        self._last: dict[str, int] = {}

    def publishers(self, topic: str, n: int) -> None:
        """The topic now has ``n`` publishers; sequence gaps count only while there is exactly one."""
        single = n == 1
        if not single or not self._single.get(topic, False):
            self._last.pop(topic, None)
        self._single[topic] = single

    def received(self, topic: str, seq: int | None) -> int:
        """One message with publication sequence number ``seq``; returns the messages it shows lost."""
        if seq is None or not self._single.get(topic, False):
            return 0
        last = self._last.get(topic)
        self._last[topic] = seq
        if last is None or seq <= last:  # first message, or the publisher restarted
            return 0
        gap = seq - last - 1
        self.lost[topic] += gap
        return gap

    def received_many(self, topic: str, seqs: list[int | None]) -> int:
        """``received`` for each of ``seqs`` in order; a gapless run (a burst) costs one list comparison."""
        if not seqs or not self._single.get(topic, False):
            return 0
        first = seqs[0]
        if first is not None and seqs == list(range(first, first + len(seqs))):
            gap = self.received(topic, first)  # only the step from the last batch can show a loss
            self._last[topic] = seqs[-1]
            return gap
        return sum(self.received(topic, seq) for seq in seqs)

    def event(self, topic: str, count_change: int) -> int:
        """A message-lost event; counted only where sequence gaps cannot be (several publishers)."""
        if self._single.get(topic, False) or count_change <= 0:
            return 0
        self.lost[topic] += int(count_change)
        return int(count_change)

    def last(self, topic: str) -> int | None:
        """The last sequence number seen on a single-publisher topic."""
        return self._last.get(topic)

    def total(self) -> int:
        return sum(self.lost.values())


def summary_line(counts: dict[str, int], path, lost: dict[str, int]) -> str:
    """The recorder's final line: messages per topic, the bag, and the losses (``lost 0`` when none)."""
    per_topic = ', '.join(f'{t}: {n}' for t, n in sorted(counts.items())) or 'no topics'
    total = sum(lost.values())
    loss = f'; LOST {total} ({", ".join(f"{t}: {n}" for t, n in sorted(lost.items()) if n)})' if total else '; lost 0'
    return f'recorded {sum(counts.values())} messages ({per_topic}) to {path}{loss}'

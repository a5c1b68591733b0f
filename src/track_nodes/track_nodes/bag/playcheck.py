"""What the player is about to play, checked before anything is published.

rosbags reads a bag's topics from ``metadata.yaml`` and its messages from the .mcap, matching them by
topic and type. When the two disagree nothing matches and the player would announce the metadata's
counts and then play nothing; an offset past the last message would do the same. ``plan_playback``
turns each such case into one line:

- a topic or type in ``metadata.yaml`` that the .mcap's channels do not have, or the reverse →
  ``BagError`` (the bag cannot be played as described; ``track-bag-recover`` rebuilds a consistent
  bag from the .mcap);
- message counts in ``metadata.yaml`` that differ from what the .mcap holds → a warning, and the
  counts announced and played are the .mcap's (every message was read and is intact);
- nothing to play at or after the start (an empty bag, or ``--start-offset`` past the last message
  of the chosen topics) → ``BagError``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from track_nodes.bag.api import RECOVER_HINT, BagError, count_messages, storage_files


@dataclass
class Plan:
    """Messages per topic in the bag (``counts``), and at or after the start among those to play."""

    counts: dict[str, int]
    to_play: int
    warnings: list[str] = field(default_factory=list)


def storage_channels(bag: Path) -> set[tuple[str, str]] | None:
    """(topic, type) of every channel in the .mcap summaries; None if a file has no summary."""
    from mcap.reader import make_reader

    out: set[tuple[str, str]] = set()
    for mcap in storage_files(bag):
        with mcap.open('rb') as f:
            summary = make_reader(f).get_summary()
        if summary is None:
            return None
        out |= {(c.topic, summary.schemas[c.schema_id].name if c.schema_id in summary.schemas else '')
                for c in summary.channels.values()}
    return out


def _listed(pairs) -> str:
    return ', '.join(f'{t} [{m}]' for t, m in sorted(pairs)) or 'nothing'


def plan_playback(reader, path: Path, topics: Sequence[str], start_ns: int, offset_s: float) -> Plan:
    """Check ``reader`` (open, of ``path``); count what playing ``topics`` from ``start_ns`` gives."""
    listed = {(c.topic, c.msgtype) for c in reader.connections}
    stored = storage_channels(path)
    if stored is not None and stored != listed:
        raise BagError(f'{path}: metadata.yaml and the .mcap disagree: metadata.yaml lists {_listed(listed - stored)}, '
                       f'the .mcap holds {_listed(stored - listed)}; nothing would play as described (rebuild '
                       f'the bag from the .mcap with: {RECOVER_HINT} {path})')
    counts, since, last = count_messages(reader, path, start_ns)
    plan = Plan(counts, sum(since.get(t, 0) for t in topics))
    said = {c.topic: c.msgcount for c in reader.connections}
    wrong = {t: (n, counts.get(t, 0)) for t, n in said.items() if n != counts.get(t, 0)}
    if wrong or reader.message_count != sum(counts.values()):
        per_topic = ', '.join(f'{t}: {a} → {b}' for t, (a, b) in sorted(wrong.items()))
        plan.warnings.append(f'{path}: metadata.yaml says {reader.message_count} messages, the .mcap holds '
                             f'{sum(counts.values())}' + (f' ({per_topic})' if per_topic else '')
                             + '; playing what the .mcap holds')
    if plan.to_play == 0:
        chosen = sum(counts.get(t, 0) for t in topics)
        if chosen == 0:
            raise BagError(f'{path}: no messages to play (the bag holds none on {", ".join(topics) or "any topic"})')
        end_s = (max(last.get(t, 0) for t in topics) - reader.start_time) * 1e-9
        raise BagError(f'{path}: --start-offset {offset_s:g} s is past the last message to play '
                       f'({end_s:.3f} s after the first message): nothing would play')
    return plan

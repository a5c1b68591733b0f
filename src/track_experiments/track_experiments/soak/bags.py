"""What a soak's bag holds: readable by rosbags and by the ``mcap`` reader (Foxglove's), and whose topics."""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

from track_msgs_py.topics import TF, TF_STATIC
from track_nodes.bag.api import BagError, mcap_problem, open_bag_checked, validate_messages


@dataclass
class BagVerdict:
    path: Path
    problem: str | None = None  # why a reader refused it; None: both read every message
    counts: dict[str, int] = field(default_factory=dict)  # messages per topic (rosbags)
    foreign: list[str] = field(default_factory=list)  # topics the run should not have recorded

    @property
    def messages(self) -> int:
        return sum(self.counts.values())


def read_bag(path: Path, regex: str) -> BagVerdict:
    """Read every message of ``path`` with both readers; topics outside ``regex`` (and tf) are foreign."""
    verdict = BagVerdict(path)
    try:
        reader = open_bag_checked(path)
        try:
            verdict.counts = validate_messages(reader, path)
        finally:
            reader.close()
        verdict.problem = mcap_problem(path, verdict.messages)
    except BagError as exc:
        verdict.problem = str(exc)
        return verdict
    own = re.compile(regex)
    verdict.foreign = sorted(t for t in verdict.counts if not own.search(t) and t not in (TF, TF_STATIC))
    return verdict

"""What a soak's bag holds: readable by rosbags and by the ``mcap`` reader (Foxglove's), and whose topics."""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

from track_msgs_py.topics import TF, TF_STATIC
from track_nodes.bag.api import BagError, open_bag_checked, storage_files, validate_messages


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
        verdict.problem = _mcap_problem(path, verdict.messages)
    except BagError as exc:
        verdict.problem = str(exc)
        return verdict
    own = re.compile(regex)
    verdict.foreign = sorted(t for t in verdict.counts if not own.search(t) and t not in (TF, TF_STATIC))
    return verdict


def _mcap_problem(path: Path, expected: int) -> str | None:
    """Decode every message with the ``mcap`` reader and the schemas embedded in the file."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    n = 0
    try:
        for mcap_file in storage_files(path):
            with mcap_file.open('rb') as f:
                for _ in make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages():
                    n += 1
    except Exception as exc:  # a broken file makes the reader raise anything
        return f'{path}: the mcap reader refused it: {type(exc).__name__}: {exc}'
    return None if n == expected else f'{path}: the mcap reader decoded {n} messages, rosbags {expected}'

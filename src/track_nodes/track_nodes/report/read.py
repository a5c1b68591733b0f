"""Reading a recorded bag back into messages, for the summaries and the pictures."""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

from rclpy.serialization import deserialize_message
from rosbags.rosbag2 import Reader

from track_nodes.bag.api import msg_class


def read_topics(bag: Path, topics: set[str] | None = None) -> dict[str, list]:
    """Deserialised messages per topic, in bag order."""
    out: dict[str, list] = defaultdict(list)
    with Reader(bag) as reader:
        conns = [c for c in reader.connections if topics is None or c.topic in topics]
        for conn, _, raw in reader.messages(connections=conns):
            out[conn.topic].append(deserialize_message(raw, msg_class(conn.msgtype)))
    return out


def topics_matching(bag: Path, predicate) -> set[str]:
    """The topics of ``bag`` for which ``predicate(topic)`` is true."""
    with Reader(bag) as reader:
        return {c.topic for c in reader.connections if predicate(c.topic)}

"""``track-bag-check BAG...``: does every message of a recording draw in RViz and Foxglove?

Reads every message whose type can break a display convention (``sensor_msgs/PointCloud2``,
``nav_msgs/Odometry``, ``geometry_msgs/PoseWithCovariance[Stamped]``,
``geometry_msgs/TwistWithCovariance[Stamped]``) and applies ``track_msgs_py.display``: every
cloud has float32 x, y, z at offsets 0, 4, 8, and no covariance has a z variance larger than its
x or y variance. ``check_bag`` returns the counts and one line per topic with a problem (how many
messages and the first reason); the command prints one line per bag and exits 1 if any fails.
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

from rclpy.serialization import deserialize_message

from track_msgs_py.display import display_problems
from track_nodes.bag.api import RECOVER_HINT, BagError, bag_path, msg_class, one_line, open_bag_checked

#: The message types ``check_bag`` reads (every other type holds no cloud and no covariance).
CHECKED_TYPES = frozenset({
    'sensor_msgs/msg/PointCloud2', 'nav_msgs/msg/Odometry', 'geometry_msgs/msg/PoseWithCovarianceStamped',
    'geometry_msgs/msg/PoseWithCovariance', 'geometry_msgs/msg/TwistWithCovarianceStamped',
    'geometry_msgs/msg/TwistWithCovariance',
})


@dataclass
class BagCheck:
    """Messages checked per topic, messages with a problem per topic, and the first reason per topic."""

    checked: Counter = field(default_factory=Counter)
    bad: Counter = field(default_factory=Counter)
    first: dict[str, str] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return not self.bad

    @property
    def problems(self) -> list[str]:
        """One line per topic with a problem: ``<topic>: <bad> of <checked> messages: <first reason>``."""
        return [f'{t}: {self.bad[t]} of {self.checked[t]} messages: {self.first[t]}' for t in sorted(self.bad)]


def check_bag(bag: Path) -> BagCheck:
    """Check every cloud and covariance of ``bag`` (a rosbag2 directory); ``BagError`` (one line) if it cannot be
    read: every chunk's CRC is checked first (``bag.integrity``), and a message that does not decode is named."""
    out = BagCheck()
    reader = open_bag_checked(Path(bag))  # opened already: not a ``with`` (it would open it again)
    topic = None
    try:
        conns = [c for c in reader.connections if c.msgtype in CHECKED_TYPES]
        for conn, _, raw in reader.messages(connections=conns):
            topic = conn.topic
            reasons = display_problems(deserialize_message(raw, msg_class(conn.msgtype)))
            out.checked[conn.topic] += 1
            if reasons:
                out.bad[conn.topic] += 1
                out.first.setdefault(conn.topic, '; '.join(reasons))
    except Exception as exc:  # garbage bytes make a reader or a decoder raise anything
        after = f' after {out.checked[topic]} messages of {topic}' if topic else ''
        raise BagError(f'{bag}: corrupt bag{after}: {one_line(exc)}; try {RECOVER_HINT} {bag}') from None
    finally:
        reader.close()
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog='track-bag-check', description='Check that every PointCloud2 of a bag has '
                                 'float32 x, y, z first and no covariance is taller in z than in x and y.')
    ap.add_argument('bags', nargs='+', help="bag directories (a name without '/' → bags/NAME/)")
    args = ap.parse_args(argv)
    failed = False
    for name in args.bags:
        try:
            res = check_bag(bag_path(name))
        except BagError as exc:
            print(f'{name}: {exc}', file=sys.stderr)
            failed = True
            continue
        n = sum(res.checked.values())
        print(f'{name}: {"ok" if res.ok else "FAILED"}: {n} messages on {len(res.checked)} topics checked')
        for line in res.problems:
            print(f'  {line}')
        failed |= not res.ok
    return 1 if failed else 0


if __name__ == '__main__':
    sys.exit(main())

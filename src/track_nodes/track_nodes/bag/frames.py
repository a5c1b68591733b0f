"""Frame check of a bag: can every frame its messages name be placed in ``map`` through its /tf and /tf_static?

``check_frames(bag)`` reads a rosbag2 bag (rosbags, no rclpy needed) and returns the problems, one
line each; an empty list means every frame is placed. ``python -m track_nodes.bag.frames BAG [ROOT]
[--stamps]`` prints them (exit 1 when there are any). What is checked:

- every ``header.frame_id`` of every message (top-level headers, and the headers of a sequence of
  stamped messages such as ``MarkerArray.markers``), except on /tf and /tf_static themselves, must
  reach ``root`` by following child → parent edges of the recorded transforms. The id is taken
  whole: ``"map#r017"`` (a track id riding in the frame, ``topics.track_frame_id``) is a frame
  that no transform names, so it is reported as not placed, as RViz and Foxglove would fail on it. An
  empty frame id is a problem, except in ``DiagnosticArray``, the RFID and IDSQ protocols' messages and
  the sonar's request and statuses and the SLAM status (no spatial content);
- ``child_frame_id`` of an Odometry on a body-frame topic (``tf.BODY_FRAME_TOPICS``: the SLAM
  laser, its truth, the sonar observer) must be placed the same way. On every other topic the
  child_frame_id names a track or target (DESIGN.md), not a frame (``tf.TRACK_CHILD_NOTE``): it is
  not placed, but it must still be a valid tf2 id (no leading '/'), since tools look it up;
- every transform has a valid pair (``tf.frame_pair_problem``), and no frame has two parents.

With ``stamps=True`` (``--stamps``) it also asks tf2's question at each message's stamp: every
dynamic (/tf) edge on the frame's chain must have transforms at or around it, i.e. the stamp lies
within the first and last stamps of that edge (tf2 interpolates between them and refuses to
extrapolate). Static (/tf_static) edges hold at every time. Without it, connectivity only.
"""

from __future__ import annotations

import sys
from bisect import bisect_left, bisect_right
from collections import defaultdict
from dataclasses import dataclass, field
from itertools import pairwise
from pathlib import Path

from track_msgs_py.tf import BODY_FRAME_TOPICS, frame_id_problem, frame_pair_problem
from track_msgs_py.topics import FRAME_MAP, TF, TF_STATIC

# No spatial content: the header carries a stamp only (the RFID protocol's angles are turns of the user;
# the IDSQ ack, revoke and leader event name sensors by id).
_NO_FRAME_TYPES = frozenset({'diagnostic_msgs/msg/DiagnosticArray', 'track_msgs/msg/RfidCommand',
                             'track_msgs/msg/RfidStep', 'track_msgs/msg/RfidFound', 'track_msgs/msg/IdsqAck',
                             'track_msgs/msg/IdsqRevoke', 'track_msgs/msg/IdsqLeaderEvent',
                             'track_msgs/msg/SonarModeCommand', 'track_msgs/msg/SonarFilterStatus',
                             'track_msgs/msg/SonarTargetStatus', 'track_msgs/msg/SlamStatus'})
_HEADER = 'std_msgs/msg/Header'


@dataclass
class FrameTree:
    """What a bag says about frames: the transform edges and where each frame is used."""

    parents: dict[str, set[str]] = field(default_factory=lambda: defaultdict(set))  # child -> parents
    used: dict[str, set[str]] = field(default_factory=lambda: defaultdict(set))     # frame -> topics
    problems: list[str] = field(default_factory=list)
    dynamic: dict[str, list[int]] = field(default_factory=lambda: defaultdict(list))  # /tf child -> stamps [ns]
    stamps: dict[tuple[str, str], list[int]] = field(default_factory=lambda: defaultdict(list))  # (frame, topic)

    def outside(self, frame: str, topic: str, root: str = FRAME_MAP) -> tuple[int, str] | None:
        """(count, edge) of ``frame``'s uses on ``topic`` stamped outside the /tf range of a chain edge."""
        chain = self.chain(frame, root) or []
        uses = sorted(self.stamps.get((frame, topic), ()))
        for child, parent in pairwise(chain):
            edge = sorted(self.dynamic.get(child, ()))
            if edge:
                inside = bisect_right(uses, edge[-1]) - bisect_left(uses, edge[0])
                if inside < len(uses):
                    return len(uses) - inside, f'{parent} -> {child} [{edge[0] * 1e-9:.3f}, {edge[-1] * 1e-9:.3f}] s'
        return None

    def chain(self, frame: str, root: str = FRAME_MAP) -> list[str] | None:
        """``frame``, its parent, ... up to ``root``; ``None`` when the chain breaks or loops."""
        out = [frame]
        while out[-1] != root:
            parents = self.parents.get(out[-1])
            if not parents or len(parents) > 1:
                return None
            (parent,) = parents
            if parent in out:
                return None
            out.append(parent)
        return out


def _frame_fields(typestore, msgtype: str) -> tuple[list[str], list[str], bool]:
    """(top-level Header fields, sequence fields of stamped messages, has a top-level child_frame_id)."""
    _, fields = typestore.fielddefs[msgtype]
    headers, sequences, child = [], [], False
    for name, (kind, detail) in fields:
        if kind.name == 'NAME' and detail == _HEADER:
            headers.append(name)
        elif kind.name == 'SEQUENCE' and detail[0][0].name == 'NAME':
            _, inner = typestore.fielddefs[detail[0][1]]
            if any(k.name == 'NAME' and d == _HEADER and n == 'header' for n, (k, d) in inner):
                sequences.append(name)
        elif name == 'child_frame_id':
            child = True
    return headers, sequences, child


class _Collector:
    """Fills a ``FrameTree`` message by message; one problem line per distinct problem."""

    def __init__(self) -> None:
        self.tree = FrameTree()
        self._seen: set[str] = set()

    def problem(self, line: str) -> None:
        if line not in self._seen:
            self._seen.add(line)
            self.tree.problems.append(line)

    def use(self, frame: str, topic: str, msgtype: str, field_name: str, stamp) -> None:
        if not frame and msgtype in _NO_FRAME_TYPES:
            return
        reason = frame_id_problem(frame, field_name)
        if reason:
            self.problem(f'{topic}: {reason}')
        else:
            self.tree.used[frame].add(topic)
            self.tree.stamps[frame, topic].append(stamp.sec * 1_000_000_000 + stamp.nanosec)

    def transforms(self, topic: str, msg) -> None:
        for tr in msg.transforms:
            reason = frame_pair_problem(tr.header.frame_id, tr.child_frame_id)
            if reason:
                self.problem(f'{topic}: {reason}')
            else:
                self.tree.parents[tr.child_frame_id].add(tr.header.frame_id)
                if topic == TF:
                    self.tree.dynamic[tr.child_frame_id].append(tr.header.stamp.sec * 1_000_000_000
                                                                 + tr.header.stamp.nanosec)

    def message(self, topic: str, msgtype: str, msg, headers: list[str], sequences: list[str], child: bool) -> None:
        for name in headers:
            header = getattr(msg, name)
            self.use(header.frame_id, topic, msgtype, f'{name}.frame_id', header.stamp)
        for name in sequences:
            for item in getattr(msg, name):
                self.use(item.header.frame_id, topic, msgtype, f'{name}[].header.frame_id', item.header.stamp)
        if child and topic in BODY_FRAME_TOPICS:
            self.use(msg.child_frame_id, topic, msgtype, 'child_frame_id', msg.header.stamp)
        elif child and msg.child_frame_id:  # a track id: not a frame, but a valid tf2 id
            reason = frame_id_problem(msg.child_frame_id, 'child_frame_id (track id)')
            if reason:
                self.problem(f'{topic}: {reason}')


def read_frame_tree(bag: Path | str) -> FrameTree:
    """Every transform edge and every frame use of ``bag`` (see the module docstring)."""
    from rosbags.rosbag2 import Reader

    from track_nodes.bag.typestore import typestore

    ts = typestore()
    out = _Collector()
    with Reader(Path(bag)) as reader:
        layout = {c.id: _frame_fields(ts, c.msgtype) for c in reader.connections}
        for conn, _, raw in reader.messages():
            if conn.topic in (TF, TF_STATIC):
                out.transforms(conn.topic, ts.deserialize_cdr(raw, conn.msgtype))
            elif any(layout[conn.id]):
                out.message(conn.topic, conn.msgtype, ts.deserialize_cdr(raw, conn.msgtype), *layout[conn.id])
    for frame, parents in out.tree.parents.items():
        if len(parents) > 1:
            out.problem(f'frame {frame!r} has several parents: {", ".join(sorted(parents))}')
    return out.tree


def check_frames(bag: Path | str, root: str = FRAME_MAP, stamps: bool = False) -> list[str]:
    """Problems of ``bag``'s frames, one line each: frames that cannot be placed in ``root``, invalid ids,
    and with ``stamps`` messages stamped where a dynamic edge of their chain has no transforms."""
    tree = read_frame_tree(bag)
    lines = list(tree.problems)
    for frame in sorted(tree.used):
        if tree.chain(frame, root) is None:
            lines.append(f'frame {frame!r} (used on {", ".join(sorted(tree.used[frame]))}) cannot be placed in '
                         f'{root!r} through /tf and /tf_static')
        elif stamps:
            for topic in sorted(tree.used[frame]):
                out = tree.outside(frame, topic, root)
                if out is not None:
                    lines.append(f'{topic}: {out[0]} of {len(tree.stamps[frame, topic])} messages in {frame!r} are '
                                 f'stamped outside the /tf range of {out[1]}')
    return lines


def main(argv: list[str] | None = None) -> int:
    args = list(sys.argv[1:] if argv is None else argv)
    stamps = '--stamps' in args
    args = [a for a in args if a != '--stamps']
    if not 1 <= len(args) <= 2:
        print('usage: python -m track_nodes.bag.frames BAG [ROOT_FRAME] [--stamps]', file=sys.stderr)
        return 2
    lines = check_frames(args[0], *args[1:], stamps=stamps)
    for line in lines:
        print(line)
    if not lines:
        print(f'{args[0]}: every frame is placed in {args[1] if len(args) > 1 else FRAME_MAP!r}')
    return 1 if lines else 0


if __name__ == '__main__':
    raise SystemExit(main())

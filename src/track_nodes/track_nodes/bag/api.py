"""Helpers shared by the recorder, the player and ``track-bag-recover``.

- ``msg_class('nav_msgs/msg/Odometry')`` → the rclpy message class, by importlib.
- ``bag_path(name)``: a bag name (→ ``bags/<name>/``) or a path containing '/'.
- ``qos_to_rosbags`` / ``qos_is_transient_local``: offered QoS as stored in rosbag2 metadata.
- ``open_bag_checked(path)``: open a rosbag2 bag for reading, turning every way a bag can be
  bad (missing, not a bag, killed recorder, truncated or corrupt .mcap) into ``BagError`` with
  one line naming the file and the problem.
- ``recording_qos(profiles)``: the recorder's subscription QoS for a topic's publishers.
"""

from __future__ import annotations

import importlib
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime

RECOVER_HINT = 'track-bag-recover'


class BagError(ValueError):
    """A bag cannot be used; the message is one line naming the file and the problem."""


def msg_class(msgtype: str) -> type:
    """The rclpy message class of ``pkg/msg/Name`` (also accepts ``pkg/Name``)."""
    parts = msgtype.split('/')
    if len(parts) == 2:
        parts = [parts[0], 'msg', parts[1]]
    if len(parts) != 3 or not all(parts):
        raise ValueError(f'invalid message type name {msgtype!r}')
    pkg, iface, name = parts
    try:
        module = importlib.import_module(f'{pkg}.{iface}')
        return getattr(module, name)
    except (ImportError, AttributeError):
        raise ValueError(f'message type {msgtype} is not installed (no module {pkg}.{iface} with {name})') from None


def bag_path(name: str) -> Path:
    """``bags/<name>/`` relative to the cwd, or ``name`` itself when it contains '/'."""
    return Path(name) if '/' in name else Path('bags') / name


def _duration_to_qos_time(d: Any) -> QosTime:
    ns = int(d.nanoseconds)
    return QosTime(ns // 1_000_000_000, ns % 1_000_000_000)


def qos_to_rosbags(profile: Any) -> Qos:
    """rclpy ``QoSProfile`` (as offered by a publisher) → rosbags ``Qos`` (same enum values)."""
    return Qos(
        QosHistory(int(profile.history)),
        int(profile.depth),
        QosReliability(int(profile.reliability)),
        QosDurability(int(profile.durability)),
        _duration_to_qos_time(profile.deadline),
        _duration_to_qos_time(profile.lifespan),
        QosLiveliness(int(profile.liveliness)),
        _duration_to_qos_time(profile.liveliness_lease_duration),
        bool(profile.avoid_ros_namespace_conventions),
    )


def qos_is_transient_local(profiles: list[Qos]) -> bool:
    """True when the recorded offered QoS says every publisher was transient-local."""
    return bool(profiles) and all(q.durability == QosDurability.TRANSIENT_LOCAL for q in profiles)


def storage_files(bag: Path) -> list[Path]:
    """The .mcap files of a bag directory (or the file itself), sorted."""
    if bag.is_file():
        return [bag]
    return sorted(bag.glob('*.mcap'))


def open_bag_checked(path: Path):
    """Open ``path`` with rosbags' ``Reader`` and check every chunk's CRC (``bag.integrity``); every problem →
    ``BagError`` (one line). A FIFO or a device where a bag's file should be is refused: reading it would hang."""
    from rosbags.rosbag2 import Reader

    if not path.exists():
        raise BagError(f'{path}: no such bag (path does not exist)')
    if path.is_dir():
        if not (path / 'metadata.yaml').exists():
            mcaps = storage_files(path)
            if mcaps:
                raise BagError(f'{path}: metadata.yaml is missing, the recorder was probably killed; '
                               f'recover the messages with: {RECOVER_HINT} {path}')
            raise BagError(f'{path}: not a rosbag2 bag (no metadata.yaml and no .mcap file)')
        for file in [path / 'metadata.yaml', *storage_files(path)]:
            _refuse_special(file)
    else:
        _refuse_special(path)
        if path.suffix != '.mcap':
            raise BagError(f'{path}: not a bag (expected a bag directory or an .mcap file)')
    try:
        reader = Reader(path)
        reader.open()
    except PermissionError as exc:
        raise BagError(f'{exc.filename or path}: cannot read bag: permission denied') from None
    except Exception as exc:  # a malformed file makes the reader raise anything (TypeError, struct.error...)
        where = _problem_file(path)
        hint = f'; try {RECOVER_HINT} {path}' if where.suffix == '.mcap' else ''
        raise BagError(f'{where}: corrupt or truncated bag: {one_line(exc)}{hint}') from None
    try:
        check_chunks(path)
    except BagError:
        reader.close()
        raise
    return reader


def check_chunks(bag: Path) -> None:
    """``BagError`` naming the first corrupt chunk of any .mcap of ``bag`` (``bag.integrity``)."""
    from track_nodes.bag.integrity import corrupt_chunk

    for mcap in storage_files(bag):
        try:
            problem = corrupt_chunk(mcap)
        except OSError as exc:
            raise BagError(f'{mcap}: cannot read bag: {exc.strerror or exc}') from None
        if problem is not None:
            raise BagError(f'{problem}; the other chunks can be recovered with: {RECOVER_HINT} {bag}')


def _refuse_special(file: Path) -> None:
    """A path that exists but is no regular file (a FIFO, a socket, a device, a directory) → BagError."""
    if file.is_dir() and file.suffix == '.mcap':
        raise BagError(f'{file}: cannot read bag: a directory where the .mcap file should be')
    if file.exists() and not file.is_dir() and not file.is_file():
        raise BagError(f'{file}: not a regular file (a FIFO, socket or device is refused: reading it would hang)')


def _problem_file(path: Path) -> Path:
    if path.is_file():
        return path
    files = storage_files(path)
    return files[0] if len(files) == 1 else path


def one_line(exc: BaseException) -> str:
    text = ' '.join(str(exc).split())
    return text or type(exc).__name__


def mcap_problem(path: Path, expected: int) -> str | None:
    """Decode every message of the bag with the ``mcap`` reader (Foxglove's) and only the schemas the file
    embeds; → why it failed, or None when it decoded ``expected`` messages (what rosbags counted)."""
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


def validate_messages(reader, path: Path, connections=()) -> dict[str, int]:
    """Iterate every message once (decompressing and checking every chunk); → count per topic."""
    return count_messages(reader, path, connections=connections)[0]


def count_messages(reader, path: Path, since: int = 0, connections=()) -> tuple[dict[str, int], ...]:
    """Read every message once (see ``validate_messages``); → per topic: count, count at or after ``since``
    (ns), last log time."""
    counts: dict[str, int] = {}
    after: dict[str, int] = {}
    last: dict[str, int] = {}
    try:
        for conn, t, _ in reader.messages(connections=connections):
            topic = conn.topic
            counts[topic] = counts.get(topic, 0) + 1
            if t >= since:
                after[topic] = after.get(topic, 0) + 1
            last[topic] = max(t, last.get(topic, t))
    except Exception as exc:  # as in open_bag_checked: garbage bytes raise anything
        raise BagError(f'{_problem_file(path)}: corrupt or truncated bag: {one_line(exc)}; '
                       f'try {RECOVER_HINT} {path}') from None
    return counts, after, last


RECORD_DEPTH = 100_000  # queue of a reliable recording subscription (Fast DDS allocates it as it fills)
RECORD_DEPTH_BEST_EFFORT = 1000  # queue of a best-effort one (nothing waits for it anyway)


def recording_qos(publisher_profiles: Sequence) -> QoSProfile:
    """Subscription QoS compatible with every publisher, with a queue deep enough for their bursts.

    Best effort if any publisher is best effort, transient-local if all are, else reliable.
    KEEP_LAST ``RECORD_DEPTH``: a reliable reader acknowledges a sample when it is queued, not when
    it is taken, so a queue shallower than a burst overwrites what the recorder has not written
    yet, and the publishers' history depth cannot be known (discovery does not carry it).
    (KEEP_ALL readers stall at Fast DDS's default limit of 5000 samples instead: measured.)
    Best-effort topics get ``RECORD_DEPTH_BEST_EFFORT``: their publishers never wait, so a deeper
    queue only delays what is lost, which the sequence gaps count.
    """
    best_effort = any(p.reliability == ReliabilityPolicy.BEST_EFFORT for p in publisher_profiles)
    transient = bool(publisher_profiles) and all(
        p.durability == DurabilityPolicy.TRANSIENT_LOCAL for p in publisher_profiles)
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=RECORD_DEPTH_BEST_EFFORT if best_effort else RECORD_DEPTH,
        reliability=ReliabilityPolicy.BEST_EFFORT if best_effort else ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if transient else DurabilityPolicy.VOLATILE)

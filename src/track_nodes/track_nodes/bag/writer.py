"""``BagWriter``: a rosbag2 bag (version 9: ``metadata.yaml`` + one .mcap) written through public APIs only.

Why: the MCAP side is ``bag.mcap_file.McapFile``, which writes what the ``mcap`` library's public
``Writer`` writes (schemas, channels, chunks with CRCs, message indexes, statistics, summary), with the
library's public record types, but takes a batch of messages at once (the recorder's hot path); no
release of rosbags or mcap can break recording through a private layout, and every chunk carries the
CRC that lets a reader find a flipped bit. What rosbag2 puts on top is written here, with the fields
rosbags' Writer writes: a ``ros2msg`` schema per type, a ``cdr`` channel per topic with its offered QoS
in the channel metadata, the ``rosbag2`` metadata record inside the .mcap and ``metadata.yaml`` beside
it (``ros_distro: jazzy``, the distribution the message definitions are from).

A chunk is written once it holds more than ``CHUNK_BYTES``, and at each ``flush`` (the file then holds
every message written so far, so a SIGKILL loses only what came after: ``track-bag-recover``).
Messages keep the bytes and log times they are given (publish time = log time, sequence 0, as rosbag2).
``checkpoint``/``rollback`` return the bag to its last flush (``bag.durable``, after a full disk).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from io import StringIO
from pathlib import Path
from typing import Any

from track_nodes.bag.mcap_file import Checkpoint as McapCheckpoint
from track_nodes.bag.mcap_file import McapFile

CHUNK_BYTES = 2**20  # a chunk is written once it holds more than this (rosbags and rosbag2 alike)
METADATA_PER_TOPIC = 1024  # [bytes] of metadata.yaml (and its copy inside the .mcap) per topic, generously
PROFILE = 'ros2'
ROS_DISTRO = 'jazzy'
IDL_PREFIX = '=' * 80 + '\nIDL: '  # a definition generated from .idl (rosbags' convention)


def library() -> str:
    """The MCAP header's library field: the writer that made the file."""
    from mcap.writer import LIBRARY_IDENTIFIER

    return f'track_nodes bag.mcap_file ({LIBRARY_IDENTIFIER} records)'


@dataclass(frozen=True)
class Checkpoint:
    """A bag at a flush: the .mcap's state and the counts ``metadata.yaml`` will give."""

    mcap: McapCheckpoint
    counts: dict[int, int]
    bounds: tuple[int, int]
    flushes: int


@dataclass
class BagConnection:
    """One topic of the bag: its MCAP channel id, type, type hash and offered QoS (rosbags ``Qos``)."""

    id: int
    topic: str
    msgtype: str
    digest: str
    serialization_format: str = 'cdr'
    offered_qos_profiles: list = field(default_factory=list)


def _yaml():
    from ruamel.yaml import YAML

    yaml = YAML(typ='safe')  # the dumper rosbags and rosbag2 files are written with
    yaml.default_flow_style = False
    return yaml


def dump_yaml(data: Any) -> str:
    out = StringIO()
    _yaml().dump(data, out)
    return out.getvalue()


def qos_text(profiles) -> str:
    """Offered QoS profiles as rosbag2 (v9) stores them in an MCAP channel's metadata."""
    from rosbags.rosbag2.metadata import dump_qos_v9

    dumped = dump_qos_v9(list(profiles))
    return dumped if isinstance(dumped, str) else dump_yaml(dumped).strip()


class BagWriter:
    """Write a new rosbag2 v9 bag at ``path`` (a directory that must not exist): ``open``, ``add_connection``,
    ``write``/``write_many``, ``flush``, ``close`` (or ``abort``). ``OSError`` from any of them is the caller's."""

    def __init__(self, path: Path | str, stream: Any = None, chunk_size: int = CHUNK_BYTES) -> None:
        self.path = Path(path)
        self.chunk_size = chunk_size  # a chunk is closed past this
        self.mcap_path = self.path / f'{self.path.name}.mcap'
        self.connections: list[BagConnection] = []
        self.counts: dict[int, int] = {}  # messages per connection id
        self.custom_data: dict[str, str] = {}
        self.min_timestamp, self.max_timestamp = 2**63 - 1, 0
        self.flushes = 0  # flushes that wrote a chunk (the summary's chunk index grows with them)
        self.schema_bytes = 0  # of the schema records (repeated in the summary)
        self._stream = stream  # None: the .mcap, created by open
        self._file = None
        self._mcap: McapFile | None = None
        self._schemas: dict[str, tuple[int, str]] = {}  # msgtype -> (schema id, type hash)
        self._unflushed = 0  # messages since the last flush

    # -- opening ----------------------------------------------------------------------------------------
    def open(self) -> BagWriter:
        """Create the bag directory and the .mcap and write its header; FileExistsError if the bag exists."""
        if self._stream is None:
            self.path.mkdir(mode=0o755, parents=True)  # FileExistsError: never overwrite a bag
            self._file = self._stream = self.mcap_path.open('xb')
        self._mcap = McapFile(self._stream, self.chunk_size)
        self._mcap.start(PROFILE, library())
        self._stream.flush()
        return self

    @property
    def stream(self) -> Any:
        """The file object the .mcap is written to."""
        return self._stream

    def set_custom_data(self, key: str, value: str) -> None:
        """A ``custom_data`` entry of ``metadata.yaml`` (string values, as rosbag2)."""
        if not isinstance(value, str):
            raise TypeError(f'custom_data {key!r}: a string is required, not {type(value).__name__}')
        self.custom_data[key] = value

    # -- topics ------------------------------------------------------------------------------------------
    def add_schema(self, msgtype: str, typestore) -> int:
        """The MCAP schema of ``msgtype`` (registered once per type): its full ``ros2msg`` definition."""
        if msgtype not in self._schemas:
            msgdef, _ = typestore.generate_msgdef(msgtype, ros_version=2)
            encoding = 'ros2idl' if msgdef.startswith(IDL_PREFIX) else 'ros2msg'
            sid = self._mcap.register_schema(msgtype, encoding, msgdef.encode())
            self.schema_bytes += len(msgtype) + len(msgdef) + 32
            self._schemas[msgtype] = (sid, typestore.hash_rihs01(msgtype))
        return self._schemas[msgtype][0]

    def add_connection(self, topic: str, msgtype: str, *, typestore, offered_qos_profiles=(),
                       serialization_format: str = 'cdr') -> BagConnection:
        """A new topic of type ``msgtype`` (known to ``typestore``); ValueError if the topic is there already."""
        if any(c.topic == topic for c in self.connections):
            raise ValueError(f'{self.path}: topic {topic} added twice')
        sid = self.add_schema(msgtype, typestore)
        qos = list(offered_qos_profiles)
        cid = self._mcap.register_channel(topic, serialization_format, sid, {'offered_qos_profiles': qos_text(qos)})
        conn = BagConnection(cid, topic, msgtype, self._schemas[msgtype][1], serialization_format, qos)
        self.connections.append(conn)
        self.counts[cid] = 0
        return conn

    # -- messages ----------------------------------------------------------------------------------------
    def write(self, conn: BagConnection, timestamp: int, data: bytes) -> None:
        self.write_many(conn, [timestamp], [data])

    def write_many(self, conn: BagConnection, stamps, raws) -> None:
        """Add ``raws`` (CDR, unchanged) of ``conn`` at log times ``stamps`` (ns), in order."""
        n = len(raws)
        if not n:
            return
        cid = conn.id
        self._mcap.add_messages(cid, stamps, raws)
        self.counts[cid] += n
        self._unflushed += n
        lo, hi = min(stamps), max(stamps)
        self.min_timestamp = min(self.min_timestamp, lo)
        self.max_timestamp = max(self.max_timestamp, hi)

    def flush(self) -> int:
        """Write the pending chunk and flush the file to the OS; → its length (every record before is complete)."""
        if self._unflushed:
            self.flushes += 1
            self._unflushed = 0
        self._mcap.flush()
        return self._stream.tell()

    def message_count(self) -> int:
        return sum(self.counts.values())

    @property
    def chunks(self) -> int:
        """Chunks written to the file so far."""
        return self._mcap.chunks

    def checkpoint(self) -> Checkpoint:
        """``flush``, then the state ``rollback`` returns to (the file up to here is complete records)."""
        self.flush()
        return Checkpoint(self._mcap.checkpoint(), dict(self.counts), (self.min_timestamp, self.max_timestamp),
                          self.flushes)

    def rollback(self, to: Checkpoint) -> None:
        """After a write error: reopen the .mcap and cut it back to ``to``; the bag can then be closed."""
        self._file = self._stream = self.mcap_path.open('r+b')
        self._mcap.rollback(to.mcap, self._stream)
        self.counts = {cid: to.counts.get(cid, 0) for cid in self.counts}
        self.min_timestamp, self.max_timestamp = to.bounds
        self.flushes, self._unflushed = to.flushes, 0

    def summary_bytes(self) -> int:
        """About what ``close`` will write after the last chunk: the MCAP summary and both metadata copies."""
        return self._mcap.summary_bytes() + 2 * METADATA_PER_TOPIC * (len(self.connections) + 1)

    # -- closing -----------------------------------------------------------------------------------------
    def metadata(self) -> dict:
        """``rosbag2_bagfile_information`` as rosbag2 and rosbags write it (version 9, one MCAP file)."""
        from rosbags.rosbag2.metadata import dump_qos_v9

        count = self.message_count()
        start = self.min_timestamp  # 2**63 - 1 in a bag without messages, as rosbags writes it
        duration = max(0, self.max_timestamp - self.min_timestamp)
        name = self.mcap_path.name
        return {
            'version': 9,
            'storage_identifier': 'mcap',
            'relative_file_paths': [name],
            'duration': {'nanoseconds': duration},
            'starting_time': {'nanoseconds_since_epoch': start},
            'message_count': count,
            'topics_with_message_count': [
                {'topic_metadata': {'name': c.topic, 'type': c.msgtype, 'serialization_format': c.serialization_format,
                                    'offered_qos_profiles': dump_qos_v9(c.offered_qos_profiles),
                                    'type_description_hash': c.digest},
                 'message_count': self.counts[c.id]}
                for c in self.connections],
            'compression_format': '',
            'compression_mode': '',
            'files': [{'path': name, 'starting_time': {'nanoseconds_since_epoch': start},
                       'duration': {'nanoseconds': duration}, 'message_count': count}],
            'custom_data': dict(self.custom_data) or None,
            'ros_distro': ROS_DISTRO,
        }

    def close(self) -> None:
        """The rosbag2 record, the MCAP summary and footer, then ``metadata.yaml`` (written last: its presence
        says the bag is complete)."""
        info = self.metadata()
        self._mcap.flush()  # the last chunk before the metadata record, as rosbag2 lays it out
        self._mcap.add_metadata('rosbag2', {'serialized_metadata': dump_yaml(info).strip()})
        self._mcap.finish()
        self._stream.flush()
        if self._file is not None:
            self._file.close()
        self.write_metadata_yaml(info)

    def write_metadata_yaml(self, info: dict) -> None:
        meta = self.path / 'metadata.yaml'
        tmp = meta.with_suffix('.yaml.tmp')
        tmp.write_text(dump_yaml({'rosbag2_bagfile_information': info}), 'utf8')
        tmp.replace(meta)

    def abort(self) -> None:
        """Close the .mcap as it is (no summary, no metadata.yaml)."""
        if self._file is not None and not self._file.closed:
            self._file.close()

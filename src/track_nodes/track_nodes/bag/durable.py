"""The recorder's bag writing, made to survive a full disk: the bag is closed up to what was written.

A full disk (``ENOSPC``), a quota (``EDQUOT``) or a file-size limit (``EFBIG``) makes a write of
the rosbags MCAP writer raise ``OSError`` in the middle of a chunk; the file then ends in a partial
record and there is no room for the summary or ``metadata.yaml``. ``DurableBag`` therefore

- keeps a *checkpoint* at every flush (``api.flush_mcap_writer``, also after each chunk that fills
  up): the file length, the chunk indexes and the message counts at that point, so
  the file up to there is complete records only;
- holds a reserve file (``RESERVE_NAME`` in the bag directory, allocated with ``posix_fallocate``)
  of about twice what the summary and ``metadata.yaml`` will take (``RESERVE_MIN`` at least),
  grown at each checkpoint as the chunk index grows;
- on an ``OSError`` (``salvage``): points the failed file object at ``/dev/null`` (its buffered
  bytes can never land), deletes the reserve, cuts the .mcap back to the checkpoint, restores the
  writer's counts to it and closes the bag normally: summary, footer and ``metadata.yaml`` describe
  exactly the messages in the file. What was taken after the checkpoint is lost, and counted.

If even that fails (the reserve was not enough, or a file-size limit leaves no room), the .mcap
still ends at the checkpoint with complete records, and ``track-bag-recover`` rebuilds the bag.

``write_many`` writes a batch of one connection's messages through ``bag.mcap_append`` (the bytes
rosbags' per-message ``write`` would write, at a fraction of its cost). This reaches into rosbags
0.11.9's private McapWriter state (as ``api.flush_mcap_writer`` does; ``api.check_mcap_writer_internals``
checks it at open, the first checkpoint reads the rest).
"""

from __future__ import annotations

import contextlib
import os
from collections import defaultdict
from dataclasses import dataclass
from io import BytesIO
from pathlib import Path

from track_nodes.bag.api import (
    RECOVER_HINT,
    check_mcap_writer_internals,
    embed_ros_distro,
    flush_mcap_writer,
    set_ros_distro,
)
from track_nodes.bag.mcap_append import CHUNK_BYTES, append, install

RESERVE_NAME = '.disk-reserve'
RESERVE_MIN = 256 * 1024  # [bytes]
METADATA_PER_TOPIC = 1024  # [bytes] of metadata.yaml (and its copy inside the .mcap) per topic, generously


def open_bag(path: Path) -> DurableBag:
    """A new rosbag2 bag (version 9, MCAP) at ``path``; ``ValueError`` (one line) if it cannot be made."""
    from rosbags.rosbag2 import StoragePlugin, Writer, WriterError

    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        writer = Writer(path, version=9, storage_plugin=StoragePlugin.MCAP)
        writer.open()
    except WriterError as exc:
        raise ValueError(f'{path}: cannot create bag: {exc}') from None
    except OSError as exc:
        raise ValueError(f'{path}: cannot create bag: {exc.strerror or exc}') from None
    try:
        check_mcap_writer_internals(writer)
        embed_ros_distro(writer)
        return DurableBag(writer, path)
    except (RuntimeError, OSError) as exc:
        writer.abort()
        with contextlib.suppress(FileNotFoundError):
            (path / RESERVE_NAME).unlink()
        if isinstance(exc, RuntimeError):
            raise
        raise ValueError(f'{path}: cannot start a bag: {exc.strerror or exc}') from None


@dataclass
class Checkpoint:
    end: int  # file length
    chunks: int
    stats: dict[int, int]  # messages per channel, as the MCAP statistics count them
    times: tuple[int, int]  # MCAP message start and end time
    counts: dict[int, int]  # messages per connection, as metadata.yaml counts them
    bounds: tuple[int, int]  # the writer's min and max timestamp


class DurableBag:
    """Wraps an open rosbags ``Writer`` (MCAP): ``write``, ``flush``, ``close``, and ``salvage`` after an OSError."""

    def __init__(self, writer, path: Path) -> None:
        self.writer, self.path = writer, Path(path)
        self.reserve = self.path / RESERVE_NAME
        self.reserved = 0
        self.failed: tuple[OSError, bool] | None = None  # the write error, and whether salvage closed the bag
        install(writer)  # chunks closed by bag.mcap_append (also by flush_mcap_writer and at close)
        self._grow(RESERVE_MIN)  # an OSError here: no room to start a bag
        self.good = self.flush()

    def written(self) -> int:
        """Messages in the file as of the last checkpoint."""
        return sum(self.good.counts.values())

    def write_many(self, conn, stamps: list[int], raws) -> None:
        """Write ``raws`` (CDR) of ``conn`` at log times ``stamps``, as that many ``Writer.write`` calls would."""
        done, n = 0, len(raws)
        while done < n:
            done += append(self.writer, conn.id, stamps[done:], raws[done:])
            if self.writer.storage.chunk.bio.tell() > CHUNK_BYTES:  # a full chunk: written, and a checkpoint
                self.flush()

    def flush(self) -> Checkpoint:
        w = self.writer
        flush_mcap_writer(w)
        s = w.storage
        self.good = Checkpoint(s.bio.tell(), len(s.chunks), dict(s.channel_stats),
                               (s.message_start_time, s.message_end_time), dict(w.counts),
                               (w.min_timestamp, w.max_timestamp))
        self._grow(self._needed())
        return self.good

    def close(self) -> None:
        self.writer.close()
        self._drop_reserve()
        set_ros_distro(self.path)

    def _needed(self) -> int:
        """About twice the bytes the summary, the MCAP metadata record and metadata.yaml will take."""
        s = self.writer.storage
        size = sum(len(x.name) + len(x.data) + 32 for x in s.schemas)
        size += sum(len(c.topic) + len(c.message_encoding) + len(c.metadata) + 32 for c in s.channels)
        size += sum(rec.tell() + 9 for rec in s.chunks) + 10 * len(s.channels) + 512
        size += 2 * METADATA_PER_TOPIC * (len(s.channels) + 1)
        return max(RESERVE_MIN, 2 * size)

    def _grow(self, size: int) -> None:
        if size <= self.reserved:
            return
        size = max(size, 2 * self.reserved)
        fd = os.open(self.reserve, os.O_WRONLY | os.O_CREAT, 0o644)
        try:
            os.posix_fallocate(fd, 0, size)
        finally:
            os.close(fd)
        self.reserved = size

    def _drop_reserve(self) -> None:
        with contextlib.suppress(FileNotFoundError):
            self.reserve.unlink()
        self.reserved = 0

    def fail(self, exc: OSError) -> None:
        """A write raised ``exc``: salvage the bag (once)."""
        if self.failed is None:
            self.failed = (exc, self.salvage())

    def failure_line(self, taken: int, lost: int) -> str:
        """The one line a recording stopped by a write error ends with: every message accounted for."""
        exc, closed = self.failed
        written = self.written()
        line = f'{self.path}: {exc.strerror or exc}: recording stopped after {taken} messages; '
        if closed:
            line += f'the bag is closed with the {written} written up to the last flush'
        else:
            line += (f'the bag could not be closed; its .mcap holds the {written} written up to the last flush: '
                     f'recover them with: {RECOVER_HINT} {self.path}')
        line += f'; {taken - written} taken after it are not in the bag'
        return line + (f'; {lost} more lost in transport' if lost else '')

    def salvage(self) -> bool:
        """After an OSError: close the bag at the last checkpoint; False if it could not be closed."""
        from rosbags.rosbag2.storage_mcap import PendingChunk

        w, good = self.writer, self.good
        s = w.storage
        if s is None:
            return False
        null = os.open(os.devnull, os.O_WRONLY)
        with contextlib.suppress(OSError, ValueError):
            os.dup2(null, s.bio.fileno())  # the failed file object's buffered bytes go nowhere
        os.close(null)
        with contextlib.suppress(OSError, ValueError):
            s.bio.close()
        self._drop_reserve()
        try:
            s.bio = s.path.open('r+b')
            s.bio.truncate(good.end)
            s.bio.seek(good.end)
            s.chunks = s.chunks[:good.chunks]
            s.chunk = PendingChunk(2**63 - 1, 0, BytesIO(), defaultdict(list))  # as rosbags makes a new one
            s.channel_stats = {cid: good.stats.get(cid, 0) for cid in s.channel_stats}
            s.message_start_time, s.message_end_time = good.times
            w.counts = {cid: good.counts.get(cid, 0) for cid in w.counts}
            w.min_timestamp, w.max_timestamp = good.bounds
            w.close()
            set_ros_distro(self.path)
            return True
        except OSError:
            with contextlib.suppress(OSError, ValueError):
                s.bio.truncate(good.end)  # complete records only, for track-bag-recover
            with contextlib.suppress(Exception):
                w.abort()
            return False

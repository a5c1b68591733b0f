"""The recorder's bag writing, made to survive a full disk: the bag is closed up to what was written.

A full disk (``ENOSPC``), a quota (``EDQUOT``) or a file-size limit (``EFBIG``) makes a write raise
``OSError`` in the middle of a chunk; the file then ends in a partial record and there is no room for
the summary or ``metadata.yaml``. ``DurableBag`` therefore

- keeps a *checkpoint* at every flush (also after each chunk that fills up): the file length, the
  chunk indexes and the message counts at that point (``BagWriter.checkpoint``), so the file up to
  there is complete records only;
- holds a reserve file (``RESERVE_NAME`` in the bag directory, allocated with ``posix_fallocate``) of
  about twice what the summary and ``metadata.yaml`` will take (``RESERVE_MIN`` at least), grown at
  each checkpoint as the chunk index grows;
- on an ``OSError`` (``salvage``): points the failed file at ``/dev/null`` (its buffered bytes can never
  land), deletes the reserve, cuts the .mcap back to the checkpoint (``BagWriter.rollback``) and closes
  the bag normally: summary, footer and ``metadata.yaml`` describe exactly the messages in the file.
  What was taken after the checkpoint is lost, and counted.

If even that fails (the reserve was not enough, or a file-size limit leaves no room), the .mcap still
ends at the checkpoint with complete records, and ``track-bag-recover`` rebuilds the bag.
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path

from track_nodes.bag.api import RECOVER_HINT
from track_nodes.bag.writer import BagWriter, Checkpoint

RESERVE_NAME = '.disk-reserve'
RESERVE_MIN = 256 * 1024  # [bytes]


def open_bag(path: Path) -> DurableBag:
    """A new rosbag2 bag (version 9, MCAP) at ``path``; ``ValueError`` (one line) if it cannot be made."""
    writer = BagWriter(path)
    try:
        writer.open()
    except OSError as exc:
        with contextlib.suppress(OSError):  # closing flushes the header: on a full disk, that fails too
            writer.abort()
        raise ValueError(f'{path}: cannot create bag: {exc.strerror or exc}') from None
    try:
        return DurableBag(writer, path)
    except OSError as exc:
        with contextlib.suppress(OSError):
            writer.abort()
        with contextlib.suppress(FileNotFoundError):
            (path / RESERVE_NAME).unlink()
        raise ValueError(f'{path}: cannot start a bag: {exc.strerror or exc}') from None


class DurableBag:
    """Wraps an open ``BagWriter``: ``write_many``, ``flush``, ``close``, and ``salvage`` after an OSError."""

    def __init__(self, writer: BagWriter, path: Path) -> None:
        self.writer, self.path = writer, Path(path)
        self.reserve = self.path / RESERVE_NAME
        self.reserved = 0
        self.failed: tuple[OSError, bool] | None = None  # the write error, and whether salvage closed the bag
        self._grow(RESERVE_MIN)  # an OSError here: no room to start a bag
        self.good = self.flush()

    def written(self) -> int:
        """Messages in the file as of the last checkpoint."""
        return sum(self.good.counts.values())

    def write_many(self, conn, stamps: list[int], raws) -> None:
        """Write ``raws`` (CDR) of ``conn`` at log times ``stamps``; a chunk that fills up makes a checkpoint."""
        chunks = self.writer.chunks
        self.writer.write_many(conn, stamps, raws)
        if self.writer.chunks != chunks:
            self.flush()

    def flush(self) -> Checkpoint:
        self.good = self.writer.checkpoint()
        self._grow(max(RESERVE_MIN, 2 * self.writer.summary_bytes()))
        return self.good

    def close(self) -> None:
        self.writer.close()
        self._drop_reserve()

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
        stream = self.writer.stream
        if stream is None:
            return False
        null = os.open(os.devnull, os.O_WRONLY)
        with contextlib.suppress(OSError, ValueError):
            os.dup2(null, stream.fileno())  # the failed file object's buffered bytes go nowhere
        os.close(null)
        with contextlib.suppress(OSError, ValueError):
            stream.close()
        self._drop_reserve()
        try:
            self.writer.rollback(self.good)
            self.writer.close()
            return True
        except OSError:
            with contextlib.suppress(OSError, ValueError):
                self.writer.stream.truncate(self.good.mcap.end)  # complete records only, for track-bag-recover
            self.writer.abort()
            return False

"""The announcement a node makes once it is up (``/track/ready``): who it is, where it runs, since when.

One ``DiagnosticStatus`` per node, named after the node's fully qualified name (``/ns/name``), level OK,
message ``ready``, ``hardware_id`` the host; the values are this record. The launcher waits for these
announcements instead of reading the graph, and two nodes of one name use them to find out which of
the two is the newcomer (``newer``): the later start, then the greater host name, then the greater pid.
"""

from __future__ import annotations

from dataclasses import dataclass

from diagnostic_msgs.msg import DiagnosticStatus

from track_msgs_py.records import DIAG_OK, RecordError, StatusRecord


@dataclass(frozen=True)
class NodeReady(StatusRecord):
    """Node ``name`` (fully qualified) of process ``pid`` on ``host``, started at ``start_ns`` (wall time,
    ns since 1970), running executable ``executable`` (``python -m track_nodes EXE``; the class otherwise)."""

    KIND = 'node ready'

    name: str
    pid: int
    host: str
    start_ns: int
    executable: str

    def __post_init__(self) -> None:
        if not self.name.startswith('/'):
            raise ValueError(f'name {self.name!r} is not fully qualified (no leading "/")')

    @property
    def order(self) -> tuple[int, str, int]:
        """Who came first: the earlier start, then the smaller host name, then the smaller pid."""
        return (self.start_ns, self.host, self.pid)

    def same_node(self, other: NodeReady) -> bool:
        return self.order == other.order

    def newer(self, other: NodeReady) -> bool:
        """True when this node started after ``other`` (both of one name): this one is the newcomer."""
        return self.order > other.order

    def where(self) -> str:
        return f'pid {self.pid} on {self.host}, {self.executable}'

    def to_msg(self) -> DiagnosticStatus:
        return self.to_status(self.name, DIAG_OK, 'ready', hardware_id=self.host)

    @classmethod
    def from_msg(cls, status: DiagnosticStatus) -> NodeReady:
        record = cls.from_status(status)
        if record.name != status.name:
            raise RecordError(f'{cls.KIND}: status name {status.name!r} differs from key name {record.name!r}')
        return record

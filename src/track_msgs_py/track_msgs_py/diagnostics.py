"""Health and named values ⇄ ``diagnostic_msgs/DiagnosticStatus`` and the ``DiagnosticArray`` of /diagnostics.

=========================  ==========================================  ===============================================
data                       message type                                fields
=========================  ==========================================  ===============================================
health / named values      diagnostic_msgs/DiagnosticStatus            ``level``, ``name``, ``message``,
                                                                       ``hardware_id``, ``values`` (KeyValue, str)
=========================  ==========================================  ===============================================

A layout of key/values that two nodes share has a typed record instead (``track_msgs_py.records``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

from track_msgs_py.stamps import stamped_header

#: DiagnosticStatus levels as ints (the message stores them as one byte).
DIAG_OK, DIAG_WARN, DIAG_ERROR, DIAG_STALE = 0, 1, 2, 3


def diagnostic_status(name: str, level: int | bytes, message: str, values: Mapping[str, object],
                      hardware_id: str = '') -> DiagnosticStatus:
    """``diagnostic_msgs/DiagnosticStatus``; ``level`` 0..3 (OK, WARN, ERROR, STALE) as int or the
    message's byte constant; each value is written with ``str()`` (floats round-trip)."""
    lvl = level[0] if isinstance(level, bytes | bytearray) and len(level) == 1 else level
    if not isinstance(lvl, int) or not DIAG_OK <= lvl <= DIAG_STALE:
        raise ValueError(f'diagnostic level must be 0..3 (OK, WARN, ERROR, STALE), got {level!r}')
    return DiagnosticStatus(level=bytes([lvl]), name=name, message=message, hardware_id=hardware_id,
                            values=[KeyValue(key=str(k), value=str(v)) for k, v in values.items()])


def diagnostic_array(t: float, statuses: Sequence[DiagnosticStatus]) -> DiagnosticArray:
    """Statuses stamped at ``t`` into the ``diagnostic_msgs/DiagnosticArray`` published on /diagnostics."""
    return DiagnosticArray(header=stamped_header(t, ''), status=list(statuses))

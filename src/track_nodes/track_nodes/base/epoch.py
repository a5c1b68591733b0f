"""The epoch of a run or a bag (``--epoch``, ``epoch:=``): the node time its /clock starts at.

Whole seconds since 1970 (at least 1: ROS time 0 means "not set"), an ISO date in UTC, or ``now``,
which each user fixes itself (the launcher: the whole minute of wall time when the clock starts;
``track-dataset``: the end of the conversion). Shared by the launcher, the ``clock`` node,
``ros2 launch`` files and ``track-dataset``, so one text means one epoch everywhere.
"""

from __future__ import annotations

from datetime import UTC, datetime


class EpochError(ValueError):
    """An epoch that is not 'now', whole seconds in [1, 2^31 - 1] or an ISO date; the message is one line."""


def parse_epoch(text: str, flag: str = '--epoch') -> int | None:
    """Whole seconds since 1970 of ``text``, or None for 'now' (fixed by the caller)."""
    if text == 'now':
        return None
    try:
        value = float(text)
    except ValueError:
        try:
            when = datetime.fromisoformat(text)
        except ValueError:
            raise EpochError(f"{flag} {text!r}: not 'now', seconds or an ISO date") from None
        value = (when if when.tzinfo else when.replace(tzinfo=UTC)).timestamp()
    if not (1 <= value <= 2**31 - 1 and value == int(value)):  # ROS time 0 means "not set"
        raise EpochError(f'{flag} {text!r}: must be whole seconds in [1, 2^31 - 1] (ROS time 0 is unset)')
    return int(value)

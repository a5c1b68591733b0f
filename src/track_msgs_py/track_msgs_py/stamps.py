"""Time ⇄ ``builtin_interfaces/Time``: float seconds and integer nanoseconds, and the stamped ``Header``.

=========================  =======================  ======================================
data                       message type             fields
=========================  =======================  ======================================
time ``t`` [s], t ≥ 0      builtin_interfaces/Time  ``sec``, ``nanosec`` (rounded to 1 ns)
=========================  =======================  ======================================

Float seconds are what the core computes with; integer nanoseconds are bag time, and convert
without a float on the way (``stamp_to_ns``, ``ns_to_stamp``).
"""

from __future__ import annotations

import math
from fractions import Fraction

from builtin_interfaces.msg import Time
from std_msgs.msg import Header

_NS_PER_S = 1_000_000_000
_INT32_MAX = 2**31 - 1


def sec_to_stamp(t: float) -> Time:
    """Float seconds → ``builtin_interfaces/Time``, rounded to the nearest nanosecond.

    Rounds the float's exact value (``Fraction``), so it is exact for integer nanoseconds:
    ``sec_to_stamp(stamp_to_sec(s)) == s`` for every stamp below 2²² s (≈ 48 days, where a float
    still resolves 1 ns), and ``stamp_to_sec(sec_to_stamp(t)) == t`` for every ``t`` that is the
    float nearest to a whole number of nanoseconds there (1.5, 0.1, 12.375), and for every float
    from 2²³ s on (wall-clock epoch times). Finer fractions are rounded to 1 ns. Negative,
    non-finite or beyond-int32 seconds raise ``ValueError``.
    """
    t = float(t)
    if not math.isfinite(t) or t < 0.0:
        raise ValueError(f'stamp must be finite and >= 0 s, got {t!r}')
    sec, nanosec = divmod(round(Fraction(t) * _NS_PER_S), _NS_PER_S)
    if sec > _INT32_MAX:
        raise ValueError(f'stamp {t!r} s does not fit builtin_interfaces/Time.sec (int32)')
    return Time(sec=int(sec), nanosec=int(nanosec))


def stamp_to_ns(stamp) -> int:
    """``Time``/``Duration`` (anything with ``sec`` and ``nanosec``) → integer nanoseconds (bag time)."""
    return int(stamp.sec) * _NS_PER_S + int(stamp.nanosec)


def ns_to_stamp(ns: int) -> Time:
    """Integer nanoseconds → an exact ``builtin_interfaces/Time`` (no float on the way)."""
    sec, nanosec = divmod(int(ns), _NS_PER_S)
    if not 0 <= sec <= _INT32_MAX:
        raise ValueError(f'stamp {ns} ns does not fit builtin_interfaces/Time')
    return Time(sec=sec, nanosec=nanosec)


def stamp_to_sec(stamp) -> float:
    """``Time``/``Duration`` → float seconds, correctly rounded (integer true division)."""
    return stamp_to_ns(stamp) / _NS_PER_S


def stamped_header(t: float, frame_id: str) -> Header:
    """``std_msgs/Header`` stamped ``sec_to_stamp(t)`` in ``frame_id``."""
    return Header(stamp=sec_to_stamp(t), frame_id=frame_id)

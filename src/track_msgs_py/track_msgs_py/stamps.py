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
from decimal import ROUND_HALF_EVEN, Decimal

from builtin_interfaces.msg import Time
from std_msgs.msg import Header

_NS_PER_S = 1_000_000_000
_INT32_MAX = 2**31 - 1


def sec_to_stamp(t: float) -> Time:
    """Float seconds → ``builtin_interfaces/Time``: the float's shortest decimal form, rounded to 1 ns.

    The shortest decimal that reads back as the same float (``repr``) is the time the float stands
    for. Near an epoch (1.8e9 s) a float resolves only 2.4e-7 s, so its exact binary value is not
    the time meant: ``1796492640.1`` is stored as …640.0999999046, whose rounding would stamp
    …640.099999905 (95 ns before the clock's step, and a bag's header stamps would disagree with its
    log times); its shortest form is …640.1, the step itself. Exact for integer nanoseconds:
    ``sec_to_stamp(stamp_to_sec(s)) == s`` for every stamp where a float still resolves 1 ns (below
    2²³ s ≈ 97 days), and ``stamp_to_sec(sec_to_stamp(t)) == t`` for every float that is the nearest
    to a whole number of nanoseconds (1.5, 0.1, 12.375) and every float from 2²³ s on (epoch times).
    Finer fractions are rounded to 1 ns (half to even). Negative, non-finite or beyond-int32 seconds
    raise ``ValueError``.
    """
    t = float(t)
    if not math.isfinite(t) or t < 0.0:
        raise ValueError(f'stamp must be finite and >= 0 s, got {t!r}')
    ns = int((Decimal(repr(t)) * _NS_PER_S).to_integral_value(rounding=ROUND_HALF_EVEN))
    sec, nanosec = divmod(ns, _NS_PER_S)
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

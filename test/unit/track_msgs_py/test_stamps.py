"""Float seconds and integer nanoseconds ⇄ builtin_interfaces/Time, also through CDR (rclpy.serialization)."""

import math

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from rclpy.serialization import deserialize_message, serialize_message

from track_msgs_py.stamps import sec_to_stamp, stamp_to_ns, stamp_to_sec


def cdr(msg):
    """Serialise and deserialise: what a subscriber or a bag reader gets."""
    return deserialize_message(serialize_message(msg), type(msg))


@pytest.mark.parametrize(('t', 'sec', 'nanosec'), [
    (0.0, 0, 0),
    (1.5, 1, 500_000_000),
    (0.123456789, 0, 123_456_789),
    (1e-9, 0, 1),
    (0.9999999999, 1, 0),  # rounds up into the next second
    (4194303.999999999, 4194303, 999_999_999),
    (1_700_000_000.25, 1_700_000_000, 250_000_000),
    (float(2**31 - 1), 2**31 - 1, 0),
])
def test_sec_to_stamp_fixed_values(t, sec, nanosec):
    s = sec_to_stamp(t)
    assert (s.sec, s.nanosec) == (sec, nanosec)
    assert stamp_to_ns(s) == sec * 10**9 + nanosec


def test_float_stamp_float_is_exact_for_integer_nanoseconds_and_large_values():
    rng = np.random.default_rng(7)
    whole_ns = rng.integers(0, 2**22 * 10**9, 500) / 1e9  # floats nearest to integer nanoseconds
    epoch = rng.uniform(1.6e9, 1.8e9, 500)  # every float from 2**23 s on
    for t in [*whole_ns, *epoch, 0.1, 0.3, 1e-9, 12.375, 2.0**31 - 1]:
        assert stamp_to_sec(sec_to_stamp(t)) == t


def test_sub_nanosecond_fractions_are_rounded():
    assert stamp_to_ns(sec_to_stamp(62.5095466604667)) == 62_509_546_660
    assert stamp_to_ns(sec_to_stamp(2.0000000015)) == 2_000_000_002  # 1.5 ns (float just above) rounds up


def test_stamp_float_stamp_is_exact_for_integer_nanoseconds():
    rng = np.random.default_rng(8)
    secs = rng.integers(0, 2**22, 500)
    nsecs = rng.integers(0, 10**9, 500)
    for sec, ns in zip(secs, nsecs, strict=True):
        s = Time(sec=int(sec), nanosec=int(ns))
        back = sec_to_stamp(stamp_to_sec(s))
        assert (back.sec, back.nanosec) == (s.sec, s.nanosec)
    # beyond 2**22 s a float cannot hold every nanosecond: within 1 ulp, and stamp_to_ns stays exact
    big = Time(sec=1_700_000_000, nanosec=123_456_789)
    assert abs(stamp_to_ns(sec_to_stamp(stamp_to_sec(big))) - stamp_to_ns(big)) <= 240
    assert stamp_to_ns(cdr(big)) == 1_700_000_000_123_456_789


@pytest.mark.parametrize('t', [-1e-9, -1.0, math.nan, math.inf, 2.0**31])
def test_sec_to_stamp_rejects_negative_non_finite_and_overflow(t):
    with pytest.raises(ValueError, match='stamp'):
        sec_to_stamp(t)


def test_epoch_times_are_stamped_at_the_time_meant_not_the_floats_binary_value():
    """Near 1.8e9 s a float resolves 2.4e-7 s: the clock's steps epoch + k·0.1 s, computed in float
    seconds, are stamped exactly (not up to ~100 ns off, as the exact binary value would give)."""
    epoch = 1_796_492_640
    for k in range(2000):
        t = epoch + k * 0.1
        assert stamp_to_ns(sec_to_stamp(t)) == epoch * 10**9 + k * 100_000_000, k
    assert stamp_to_ns(sec_to_stamp(1796492640.973)) == 1796492640_973000000   # a data time in ms, shifted

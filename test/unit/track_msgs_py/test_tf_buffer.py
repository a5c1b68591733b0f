"""The transform buffer over /tf and /tf_static: chains, interpolation, refusals, bounds, planar CV states."""

import math

import numpy as np
import pytest
from tf2_msgs.msg import TFMessage

from track_msgs_py.covariance import NOT_ESTIMATED_VARIANCE
from track_msgs_py.tf import planar_transform
from track_msgs_py.tf_buffer import DT, TransformBuffer, move_cv_states


def _tf(*transforms):
    return TFMessage(transforms=list(transforms))


def test_chain_of_a_moving_ship_and_a_static_radar_interpolates():
    b = TransformBuffer(tolerance=0.1)
    assert b.add(_tf(planar_transform(0.0, 'ship', 'radar', 2.0, 0.0, math.pi / 2)), static=True) == []
    b.add(_tf(planar_transform(10.0, 'map', 'ship', 100.0, 0.0, 0.0)))
    b.add(_tf(planar_transform(12.0, 'map', 'ship', 104.0, 0.0, 0.0)))
    T, reason = b.lookup('map', 'radar', 11.0)
    assert reason is None
    np.testing.assert_allclose(T[:2, 3], [104.0, 0.0], atol=1e-9)                 # ship at 102 + radar 2 ahead
    assert math.atan2(T[1, 0], T[0, 0]) == pytest.approx(math.pi / 2)
    Ti, _ = b.lookup('radar', 'map', 11.0)
    np.testing.assert_allclose(Ti @ T, np.eye(4), atol=1e-9)


def test_unknown_frame_too_old_and_before_the_buffer_are_refused_with_names():
    b = TransformBuffer(tolerance=0.1)
    b.add(_tf(planar_transform(10.0, 'map', 'radar', 0.0, 0.0, 0.0)))
    assert "unknown frame 'nowhere'" in b.lookup('map', 'nowhere', 10.0)[1]
    assert b.lookup('map', 'radar', 10.05)[1] is None                              # within the tolerance
    assert 'too old' in b.lookup('map', 'radar', 10.5)[1] and "'radar'" in b.lookup('map', 'radar', 10.5)[1]
    assert 'not known at' in b.lookup('map', 'radar', 9.0)[1]
    b.add(_tf(planar_transform(10.0, 'odom', 'base', 0.0, 0.0, 0.0)))
    assert 'no transform chain' in b.lookup('map', 'base', 10.0)[1]


def test_bad_transforms_are_skipped_with_a_reason_and_history_is_bounded():
    b = TransformBuffer(history=1.0)
    bad = planar_transform(1.0, 'map', 'radar', 0.0, 0.0, 0.0)
    bad.transform.rotation.w = 0.0
    assert 'zero quaternion' in b.add(_tf(bad))[0]
    for k in range(100):
        b.add(_tf(planar_transform(0.1 * k, 'map', 'radar', k, 0.0, 0.0)))
    assert 'before the latest' in b.add(_tf(planar_transform(0.0, 'map', 'radar', 0.0, 0.0, 0.0)))[0]
    times = b.edges['radar'].times
    assert times[-1] - times[0] <= 1.0 + 1e-9 and len(times) <= 11


def test_move_cv_states_with_a_turning_frame():
    """A point fixed in a frame turning at ω about the map origin moves at ω × r in the map."""
    omega = 0.1
    T0, T1 = (planar_transform(t, 'map', 'f', 0.0, 0.0, omega * t) for t in (0.0, DT))
    b = TransformBuffer()
    b.add(_tf(T0))
    b.add(_tf(T1))
    T, _ = b.lookup('map', 'f', DT)
    motion = b.motion('map', 'f', DT)
    x = np.array([[10.0, 0.0, 0.0, 0.0]])                   # at rest 10 m along the frame's x axis
    P = np.diag([4.0, 0.01, 4.0, 0.01])[None]
    xm, Pm = move_cv_states(T, x, P, motion)
    yaw = omega * DT
    np.testing.assert_allclose(xm[0, [0, 2]], [10 * math.cos(yaw), 10 * math.sin(yaw)], atol=1e-9)
    np.testing.assert_allclose(xm[0, [1, 3]], omega * 10 * np.array([-math.sin(yaw), math.cos(yaw)]), atol=1e-9)
    assert np.allclose(Pm[0], Pm[0].T) and np.all(np.linalg.eigvalsh(Pm[0]) > 0)
    # a velocity not estimated stays so
    Pn = P.copy()
    Pn[0, 1, 1] = Pn[0, 3, 3] = NOT_ESTIMATED_VARIANCE
    xn, Pn2 = move_cv_states(T, x, Pn, motion)
    assert xn[0, 1] == xn[0, 3] == 0.0 and Pn2[0, 1, 1] == NOT_ESTIMATED_VARIANCE

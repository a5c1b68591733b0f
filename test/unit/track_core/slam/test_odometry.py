"""Odometry → unicycle inputs, the odom track and map → odom (track_core.slam.odometry, track_core.filters.poses)."""

from __future__ import annotations

import numpy as np
import pytest

from track_core.filters import invert_pose as inverse
from track_core.filters.poses import OdomTrack, compose, relative_pose, unicycle_arc, unicycle_from_increment
from track_core.slam.models import UnicycleParams, VehicleParams, acfr_to_unicycle, process_noise, vehicle_step
from track_core.slam.odometry import OdometryInputs, map_to_odom, sensor_to_base


def test_arc_and_its_inverse_round_trip_vectorised():
    rng = np.random.default_rng(0)
    p0 = rng.uniform(-5, 5, (50, 3))
    v, w, dt = rng.uniform(-2, 3, 50), rng.uniform(-1.5, 1.5, 50), 0.2
    p1 = unicycle_arc(p0, v, w, dt)
    v2, w2, lat = unicycle_from_increment(p0, p1, dt)
    np.testing.assert_allclose(v2, v, atol=1e-12)
    np.testing.assert_allclose(w2, w, atol=1e-12)
    np.testing.assert_allclose(lat, 0.0, atol=1e-12)
    # a sideways slip is not a unicycle motion: reported, not turned into speed
    _, _, lat = unicycle_from_increment(np.zeros(3), np.array([0.0, 0.3, 0.0]), 1.0)
    assert lat == pytest.approx(0.3)


def test_compose_inverse_and_map_to_odom():
    rng = np.random.default_rng(1)
    a, b = rng.uniform(-3, 3, 3), rng.uniform(-3, 3, 3)
    np.testing.assert_allclose(compose(a, relative_pose(a, b)), b, atol=1e-12)
    np.testing.assert_allclose(compose(a, inverse(a)), 0.0, atol=1e-12)
    base_map, base_odom = rng.uniform(-3, 3, 3), rng.uniform(-3, 3, 3)
    # map → odom → base_link places the robot at its estimate
    np.testing.assert_allclose(compose(map_to_odom(base_map, base_odom), base_odom), base_map, atol=1e-12)


def test_unicycle_model_with_the_acfr_twist_is_the_acfr_model():
    """The ACFR car is the unicycle at its rear-axle centre (v_c, ω = v_c tan α / L), laser at (a, b):
    same step and, with Σ_(v,ω) = J Σ Jᵀ, the same process noise."""
    vp = VehicleParams()
    uni = UnicycleParams(a=vp.a, b=vp.b)
    rng = np.random.default_rng(2)
    pose, ve, al = rng.uniform(-3, 3, 3), 3.0, 0.2
    v, w, J = acfr_to_unicycle(ve, al, vp)
    np.testing.assert_allclose(vehicle_step(pose, np.array([v, w]), 0.025, uni),
                               vehicle_step(pose, np.array([ve, al]), 0.025, vp), atol=1e-12)
    Su = np.diag([0.5**2, np.deg2rad(3.0) ** 2])
    np.testing.assert_allclose(process_noise(pose, np.array([v, w]), 0.025, (0, 0), vp=uni, Su=J @ Su @ J.T),
                               process_noise(pose, np.array([ve, al]), 0.025, (0.5, np.deg2rad(3.0)), vp=vp),
                               atol=1e-15)


def test_odometry_inputs_twist_and_increments():
    cov = np.diag([0.01, 0.001])
    tw = OdometryInputs('twist')
    assert tw.offer(1.0, np.zeros(3), 0.5, 0.1, cov, tag=7) == [(1.0, 0.5, 0.1, cov, 7)]
    inc = OdometryInputs('increments')
    p0 = np.array([1.0, 2.0, 0.3])
    p1 = unicycle_arc(p0, 1.2, -0.4, 0.5)
    assert inc.offer(10.0, p0, 0.0, 0.0, cov, tag='a') == []    # the first message only starts the interval
    (t, v, w, c, tag), = inc.offer(10.5, p1, 0.0, 0.0, None, tag='b')
    assert t == 10.0 and c is cov and tag == 'a'    # stamped at the interval's start, with its noise
    assert v == pytest.approx(1.2) and w == pytest.approx(-0.4)
    assert inc.offer(10.5, p1, 0.0, 0.0, None) == []                 # no time elapsed: nothing to apply
    with pytest.raises(ValueError, match='motion'):
        OdometryInputs('pose')


def test_odom_track_interpolates_and_dead_reckons():
    tr = OdomTrack()
    with pytest.raises(LookupError):
        tr.pose_at(0.0)
    tr.add(0.0, np.array([0.0, 0.0, 3.0]))
    tr.add(1.0, np.array([1.0, 0.0, -3.0]), v=1.0, w=0.0)            # yaw across ±π: the short way
    p = tr.pose_at(0.5)
    assert p[0] == pytest.approx(0.5) and abs(p[2]) == pytest.approx(np.pi, abs=1e-9)
    np.testing.assert_allclose(tr.pose_at(2.0), [1.0 + np.cos(-3.0), np.sin(-3.0), -3.0], atol=1e-12)
    dr = OdomTrack()
    dr.integrate(0.0, 1.0, 0.5)
    dr.integrate(2.0, 0.0, 0.0)
    np.testing.assert_allclose(dr.pose_at(2.0), unicycle_arc(np.zeros(3), 1.0, 0.5, 2.0), atol=1e-12)


def test_sensor_to_base_moves_pose_and_covariance():
    P = np.diag([0.1, 0.2, 0.01])
    base, Pb = sensor_to_base(np.array([3.78, 0.5, 0.0]), P, 3.78, 0.5)
    np.testing.assert_allclose(base, 0.0, atol=1e-12)
    assert Pb[2, 2] == 0.01 and Pb[1, 1] == pytest.approx(0.2 + 3.78**2 * 0.01)

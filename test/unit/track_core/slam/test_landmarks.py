"""The point-landmark extractor (track_core.slam.landmarks) on ray-cast scans of poles among walls."""

from __future__ import annotations

import numpy as np
import pytest

from track_core.slam.landmarks import ExtractorParams, extract, to_eq5_bearing
from track_core.slam.sim import raycast_scan

WALLS = np.array([[[-5, 8], [20, 8]], [[20, 8], [20, -8]], [[20, -8], [-5, -8]], [[-5, -8], [-5, 8]]], float)
POLES = np.array([[6.0, 3.0], [10.0, -4.0], [14.0, 1.0], [-2.0, 5.0]])
RADII = np.array([0.15, 0.2, 0.1, 0.25])
ANGLES = np.linspace(-np.pi, np.pi, 1440, endpoint=False)   # 0.25° beams, 360°


def _scan(pose, sigma=0.01, seed=1):
    return raycast_scan(pose, ANGLES, WALLS, POLES, RADII, 30.0, sigma, np.random.default_rng(seed))


@pytest.mark.parametrize('seed', [1, 2, 3])
def test_finds_every_pole_and_no_wall(seed):
    pose = np.array([0.5, -0.5, 0.3])
    det = extract(_scan(pose, seed=seed), ANGLES[0], ANGLES[1] - ANGLES[0], 0.05, 30.0)
    rel = POLES - pose[:2]
    true_r = np.hypot(*rel.T)
    true_b = np.arctan2(rel[:, 1], rel[:, 0]) - pose[2]
    assert len(det) == len(POLES)                                   # the walls and their corners are not poles
    order = np.argsort(det.bearing)
    ref = np.argsort(true_b)
    np.testing.assert_allclose(det.range[order], true_r[ref], atol=0.05)
    np.testing.assert_allclose(det.bearing[order], true_b[ref], atol=np.deg2rad(1.0))
    np.testing.assert_allclose(det.diameter[order], 2 * RADII[ref], atol=0.06)
    assert np.all(np.linalg.eigvalsh(det.covariance) > 0)


def test_limits_and_garbage():
    inc = ANGLES[1] - ANGLES[0]
    r = _scan(np.zeros(3))
    # a pole wider than max_diameter is refused
    det = extract(r, ANGLES[0], inc, 0.05, 30.0, ExtractorParams(max_diameter=0.25))
    assert len(det) == 1 and det.diameter[0] == pytest.approx(0.2, abs=0.05)  # only the 0.2 m pole
    # NaN, negative, inf and beyond-range beams are ignored, never an exception
    bad = r.copy()
    bad[::7] = np.nan
    bad[1::11] = -1.0
    assert len(extract(bad, ANGLES[0], inc, 0.05, 30.0)) <= len(POLES)
    assert len(extract(np.full(100, np.nan), 0.0, 0.01, 0.05, 30.0)) == 0
    assert len(extract(np.zeros(0), 0.0, 0.01, 0.05, 30.0)) == 0
    assert len(extract(r, ANGLES[0], 0.0, 0.05, 30.0)) == 0         # a zero increment: no geometry
    with pytest.raises(ValueError, match='min_points'):
        ExtractorParams(min_points=2)


def test_eq5_bearing_is_rep103_plus_a_quarter_turn():
    np.testing.assert_allclose(to_eq5_bearing(np.array([0.0, -np.pi / 2, np.pi / 2])), [np.pi / 2, 0.0, np.pi])


def test_eq5_bearing_keeps_an_ulp_above_pi_at_the_left_edge():
    left = np.pi - np.pi / 2   # a 180° laser's leftmost bearing, REP-103, as a round trip produces it
    assert to_eq5_bearing(np.array([left]))[0] > 3.0        # π (or an ulp above), never −π
    assert to_eq5_bearing(np.array([np.pi]))[0] == pytest.approx(-np.pi / 2)   # behind-left: wrapped

import numpy as np
import pytest

from track_core.filters import circular_mean, invert_pose, wrap_angle


def test_wrap_half_open_interval():
    a = np.array([np.pi, -np.pi, 3 * np.pi, 0.0, 2 * np.pi + 0.1, -0.1])
    w = wrap_angle(a)
    assert np.all(w > -np.pi) and np.all(w <= np.pi)
    np.testing.assert_allclose(w, [np.pi, np.pi, np.pi, 0.0, 0.1, -0.1], atol=1e-12)


def test_circular_mean_across_pi():
    a = np.array([np.pi - 0.1, -np.pi + 0.1])
    assert abs(circular_mean(a)) == pytest.approx(np.pi)
    assert circular_mean(np.array([0.1, 0.3]), np.array([1.0, 3.0])) == pytest.approx(0.25, abs=2e-3)


def _compose(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    return np.stack([a[..., 0] + c * b[..., 0] - s * b[..., 1], a[..., 1] + s * b[..., 0] + c * b[..., 1],
                     wrap_angle(a[..., 2] + b[..., 2])], axis=-1)


def test_invert_pose_composes_to_the_identity_and_places_the_origin():
    rng = np.random.default_rng(3)
    poses = np.column_stack([rng.uniform(-50, 50, (20, 2)), rng.uniform(-np.pi, np.pi, 20)])
    inv = invert_pose(poses)
    np.testing.assert_allclose(_compose(poses, inv), 0.0, atol=1e-12)
    np.testing.assert_allclose(_compose(inv, poses), 0.0, atol=1e-12)
    # B at (3, 4) facing +y in A: A's origin is at (-4, 3) in B, facing -π/2
    np.testing.assert_allclose(invert_pose(np.array([3.0, 4.0, np.pi / 2])), [-4.0, 3.0, -np.pi / 2], atol=1e-12)

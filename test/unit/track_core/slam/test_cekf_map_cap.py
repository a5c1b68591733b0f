"""The CEKF's map-size cap: beyond ``max_landmarks`` no observation starts a landmark; each is counted,
the mapped landmarks are still fused, and the state stops growing (a run of days stays bounded)."""

from __future__ import annotations

import numpy as np
import pytest

from track_core.slam.cekf import CekfSlam, SlamParams
from track_core.slam.models import observe


def _trees(n: int) -> np.ndarray:
    """``n`` trees in view of the origin pose, far apart (each outside every other's new-landmark gate)."""
    bearing = np.linspace(0.3, np.pi - 0.3, n)
    return np.column_stack([15.0 * np.cos(bearing), 15.0 * np.sin(bearing)])


@pytest.mark.parametrize('compressed', [False, True])
@pytest.mark.parametrize('min_obs', [1, 2])
def test_new_landmarks_beyond_the_cap_are_refused_and_counted(compressed, min_obs):
    trees = _trees(9)
    f = CekfSlam(np.zeros(3), np.eye(3) * 1e-6, SlamParams(max_landmarks=5, min_obs=min_obs), compressed=compressed)
    f.association_log = []
    for k in range(3):  # three trees more per scan, each scan seeing every tree so far
        z = observe(np.zeros(3), trees[:3 * (k + 1)])
        for _ in range(min_obs):
            f.update(z)
    assert f.n_landmarks == 5
    np.testing.assert_allclose(f.landmarks(), trees[:5], atol=1e-6)
    mapped = np.concatenate([s.new for s in f.association_log])
    assert mapped.tolist() == list(range(5))  # the log names only the landmarks that were made
    # the four unmapped trees are refused again whenever they would be mapped; the five mapped ones are fused
    refused = f.n_refused_landmarks
    assert refused >= 4
    for _ in range(min_obs):
        a = f.update(observe(np.zeros(3), trees))
        assert a.obs.size == 5 and f.n_landmarks == 5
    assert f.n_refused_landmarks == refused + 4
    _, P = f.mean_cov()
    assert P.shape == (3 + 2 * 5, 3 + 2 * 5)


def test_the_default_cap_is_far_above_victoria_park_and_must_be_positive():
    assert SlamParams().max_landmarks >= 5 * 277  # Victoria Park maps 277 landmarks (docs/results/slam.md)
    with pytest.raises(ValueError, match='max_landmarks = 0: must be >= 1'):
        SlamParams(max_landmarks=0)

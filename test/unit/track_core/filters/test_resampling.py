import numpy as np
import pytest

from track_core.filters import effective_sample_size, normalize_log_weights, systematic_resample


def test_normalize_and_ess():
    w, lse = normalize_log_weights(np.array([1000.0, 1000.0, -np.inf]))
    np.testing.assert_allclose(w, [0.5, 0.5, 0.0])
    assert lse == pytest.approx(1000.0 + np.log(2.0))
    assert effective_sample_size(np.full(10, 0.1)) == pytest.approx(10.0)
    assert effective_sample_size(np.eye(5)[0]) == pytest.approx(1.0)
    with pytest.raises(ValueError, match='log-weight'):
        normalize_log_weights(np.array([-np.inf, np.nan]))


def test_systematic_counts_are_floor_or_ceil():
    rng = np.random.default_rng(0)
    w = rng.random(50)
    w /= w.sum()
    for _ in range(20):
        counts = np.bincount(systematic_resample(w, rng), minlength=50)
        assert counts.sum() == 50
        assert np.all(counts >= np.floor(50 * w) - 1e-9) and np.all(counts <= np.ceil(50 * w) + 1e-9)


@pytest.mark.parametrize('n', [7, 50, 400])
def test_systematic_draws_n_of_any_count(n):
    """n draws from 50 weighted particles (fewer: prior boosting keeps N of init_boost·N)."""
    rng = np.random.default_rng(1)
    w = rng.random(50)
    w /= w.sum()
    idx = systematic_resample(w, rng, n)
    counts = np.bincount(idx, minlength=50)
    assert idx.size == n and idx.max() < 50
    assert np.all(counts >= np.floor(n * w) - 1e-9) and np.all(counts <= np.ceil(n * w) + 1e-9)

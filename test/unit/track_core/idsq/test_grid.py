import numpy as np
import pytest

from track_core.idsq.grid import (
    SPARSITY_THRESHOLD,
    GridSpec,
    SparseBelief,
    diffuse,
    disk_kernel,
    estimate,
    from_dense,
    sparsify,
    uniform_belief,
)

GRID = GridSpec.for_field(150.0, 250.0, 5.0)


def _point(ix: int, iy: int) -> SparseBelief:
    return SparseBelief(GRID, np.array([iy * GRID.nx + ix]), np.array([1.0]))


def test_field_grid_and_uniform_belief():
    assert (GRID.nx, GRID.ny, GRID.n_cells) == (30, 50, 1500)
    b = uniform_belief(GRID)
    assert b.size == 1500 and np.isclose(b.mass.sum(), 1.0)
    e = estimate(b)
    np.testing.assert_allclose(e.mean, [75.0, 125.0])
    # discrete uniform variance: (n² − 1)/12 · cell² per axis
    assert np.isclose(e.spread, (30**2 - 1) / 12 * 25 + (50**2 - 1) / 12 * 25)


def test_centers_and_index_roundtrip():
    idx = np.array([0, 29, 30, 1499])
    c = GRID.centers(idx)
    np.testing.assert_allclose(c[0], [2.5, 2.5])
    np.testing.assert_allclose(c[-1], [147.5, 247.5])
    np.testing.assert_array_equal(GRID.index_of(c), idx)


def test_sparsify_drops_below_relative_threshold_and_renormalises():
    b = sparsify(GRID, np.array([5, 3, 7]), np.array([1.0, SPARSITY_THRESHOLD * 0.5, 0.5]))
    np.testing.assert_array_equal(b.idx, [5, 7])
    np.testing.assert_allclose(b.mass, [2 / 3, 1 / 3])
    with pytest.raises(ValueError, match='no positive'):
        sparsify(GRID, np.array([1]), np.array([0.0]))


def test_disk_kernel_is_normalised_symmetric_and_area_weighted():
    k = disk_kernel(7.5, 5.0)
    assert k.shape == (3, 3) and np.isclose(k.sum(), 1.0)
    np.testing.assert_allclose(k, k.T)
    np.testing.assert_allclose(k, k[::-1, ::-1])
    # centre cell fully inside, corners partly: area fraction of the corner cell is < 1
    assert k[1, 1] > k[0, 1] > k[0, 0] > 0


def test_diffuse_keeps_mass_and_grows_spread_like_the_disk():
    b = diffuse(_point(15, 25), 7.5)
    assert np.isclose(b.mass.sum(), 1.0) and b.size == 9
    e = estimate(b)
    np.testing.assert_allclose(e.mean, GRID.centers(np.array([25 * 30 + 15]))[0], atol=1e-9)
    # a uniform disk of radius R has trace covariance R²/2 = 28.1 m²; on 5 m cells within 25 %
    assert 0.75 * 28.125 < e.spread < 1.25 * 28.125
    many = _point(15, 25)
    for _ in range(10):
        many = diffuse(many, 7.5)
    assert np.isclose(many.mass.sum(), 1.0)
    assert 10 * 0.75 * 28.125 < estimate(many).spread < 10 * 1.25 * 28.125  # variances add


def test_diffuse_at_the_field_edge_crops_and_renormalises():
    b = diffuse(_point(0, 0), 7.5)
    assert b.size == 4 and np.isclose(b.mass.sum(), 1.0)
    assert np.all(b.idx >= 0)


def test_diffuse_keeps_sparsity():
    dense = np.zeros((GRID.ny, GRID.nx))
    dense[20:23, 10:13] = 1.0
    b = diffuse(from_dense(GRID, dense), 7.5)
    assert b.size == 25  # 3×3 block dilated by one cell each side, not the whole field

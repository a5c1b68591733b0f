"""SyntheticSea: the density stays constant as the sea grows; every ship is a radar and a patrol track."""

import numpy as np
import pytest

from track_experiments.fusion.sea import DENSITY, SyntheticSea


@pytest.mark.parametrize('n', [200, 2000])
def test_the_sea_grows_at_a_constant_density(n):
    sea = SyntheticSea(n, np.random.default_rng(0))
    assert sea.ships / (sea.side / 1000.0) ** 2 == pytest.approx(DENSITY)
    assert len(sea.ids) == len(sea.sources) == n and sorted(set(sea.sources)) == ['/patrol', '/radar']
    mu, R = sea.step(1.0)
    assert mu.shape == (n, 2) and R.shape == (n, 2, 2) and np.all(np.linalg.eigvalsh(R) > 0)


def test_reports_scatter_around_the_ship_with_their_covariance():
    sea = SyntheticSea(400, np.random.default_rng(1))
    d = np.array([sea.step(0.0)[0] - sea.pos[sea._ship] for _ in range(200)])        # (200, n, 2)
    m2 = np.einsum('kni,nij,knj->kn', d, np.linalg.inv(sea.R), d)
    assert np.mean(m2) == pytest.approx(2.0, rel=0.05)        # χ²₂: 80,000 draws

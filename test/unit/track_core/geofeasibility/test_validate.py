import numpy as np
import pytest

from track_core.geofeasibility import check_pairs, score

GOOD = np.eye(2)


def _batch(n=5):
    return np.zeros((n, 2)), np.tile(GOOD, (n, 1, 1)), np.ones((n, 2)), np.tile(GOOD, (n, 1, 1))


@pytest.mark.parametrize('method', ['mc', 'glr', 'glr_thresholded', 'exact'])
@pytest.mark.parametrize(('arg', 'bad', 'reason'), [
    (1, np.array([[1.0, 0.0], [0.0, -1.0]]), 'not positive definite'),
    (3, np.array([[1.0, 1.0], [1.0, 1.0]]), 'not positive definite'),      # singular
    (1, np.array([[1.0, 0.0], [0.0, 0.0]]), 'not positive definite'),
    (3, np.array([[1.0, 0.5], [0.2, 1.0]]), 'not symmetric'),
    (1, np.array([[1.0, np.nan], [np.nan, 1.0]]), 'non-finite'),
    (3, np.array([[np.inf, 0.0], [0.0, 1.0]]), 'non-finite'),
    (0, np.array([np.nan, 0.0]), 'non-finite'),
    (2, np.array([0.0, -np.inf]), 'non-finite'),
])
def test_bad_input_names_pair_argument_and_reason(method, arg, bad, reason):
    args = list(_batch())
    args[arg] = args[arg].copy()
    args[arg][3] = bad
    name = ('mu1', 'R1', 'mu2', 'R2')[arg]
    with pytest.raises(ValueError, match=rf'pair 3: {name} .*{reason}'):
        score(*args, method=method, rng=np.random.default_rng(0))


def test_message_counts_further_bad_pairs():
    args = list(_batch(6))
    args[1] = args[1].copy()
    args[1][[2, 4, 5]] = -np.eye(2)
    with pytest.raises(ValueError, match=r'pair 2: R1 .*and 2 more bad pairs'):
        score(*args, method='glr')


def test_tiny_asymmetry_from_rounding_is_accepted_and_symmetrised():
    R = np.array([[2.0, 0.3 + 1e-14], [0.3, 1.0]])
    _, c1, _, _, single = check_pairs(np.zeros(2), R, np.zeros(2), np.eye(2))
    assert single and c1[0, 0, 1] == c1[0, 1, 0]


def test_shapes_broadcast_and_single_pair_gives_0d():
    g = score(np.zeros(2), GOOD, np.ones(2), GOOD, 'glr')
    assert isinstance(g, np.ndarray) and g.shape == ()
    g = score(np.zeros((4, 2)), GOOD, np.ones(2), np.tile(GOOD, (4, 1, 1)), 'glr')
    assert g.shape == (4,)
    with pytest.raises(ValueError, match='batch sizes differ'):
        score(np.zeros((4, 2)), GOOD, np.ones((3, 2)), GOOD, 'glr')
    with pytest.raises(ValueError, match='shape'):
        score(np.zeros(3), GOOD, np.ones(2), GOOD, 'glr')
    with pytest.raises(ValueError, match='unknown method'):
        score(np.zeros(2), GOOD, np.ones(2), GOOD, 'area')

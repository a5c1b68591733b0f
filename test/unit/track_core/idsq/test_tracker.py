import numpy as np
import pytest

from track_core.idsq.grid import GridSpec, estimate, sparsify, uniform_belief
from track_core.idsq.handoff import receive_handoff
from track_core.idsq.models import DEG, TrackerParams, bearings, likelihood
from track_core.idsq.network import SensorLayout
from track_core.idsq.tracker import centralized_step, leader_step, select_next, update

GRID = GridSpec.for_field()
P = TrackerParams()
POS = np.array([[40.0, 100.0], [75.0, 110.0], [110.0, 100.0], [75.0, 140.0], [60.0, 80.0], [90.0, 130.0]])
DOA = np.array([False, True, False, True, False, False])
LAYOUT = SensorLayout(POS, DOA)
TRUTH = np.array([80.0, 120.0])


def _z(k: int) -> float:
    if DOA[k]:
        return float(bearings(TRUTH, POS[k]))
    return 40.0 / float(np.linalg.norm(TRUTH - POS[k]))


def test_doa_update_concentrates_on_the_bearing_line():
    post, ok = update(uniform_belief(GRID), _z(3), POS[3], True, P)
    assert ok
    err = np.abs(np.angle(np.exp(1j * (bearings(post.centers(), POS[3]) - _z(3)))))
    assert np.sum(post.mass * (err < 20 * DEG)) > 0.8


def test_zero_likelihood_update_is_skipped():
    b = uniform_belief(GRID)
    post, ok = update(b, -1e3, POS[0], False, P)  # a negative amplitude far below a_lo / r everywhere
    assert not ok and post is b
    with pytest.raises(ValueError, match='finite'):
        update(b, float('nan'), POS[0], False, P)


def test_an_amplitude_above_the_grids_reach_puts_the_belief_at_the_sensor():
    """A target 0.8 m from an acoustic sensor between cell centres: z = A/r = 50 needs r <= a_hi/z = 1.6 m,
    nearer than any centre (2.5 m and more), so eq. 6 is 0 on every cell; z is clipped to a_hi/r_min."""
    sensor = np.array([75.0, 120.0])  # a cell corner: the nearest centres are 3.5 m away
    z = 40.0 / 0.8
    post, ok = update(uniform_belief(GRID), z, sensor, False, P)
    assert ok
    e = estimate(post)
    assert np.linalg.norm(e.mean - sensor) < 2.0 and post.size == 4  # the four cells round the sensor
    b = uniform_belief(GRID)
    same, _ = update(b, 40.0 / 20.0, sensor, False, P)  # z the grid can explain: eq. 6 as it is
    want = sparsify(GRID, b.idx, b.mass * likelihood(2.0, b.centers(), sensor, False, P), P.sparsity)
    np.testing.assert_array_equal(same.idx, want.idx)
    np.testing.assert_array_equal(same.mass, want.mass)


def test_leader_step_chooses_a_candidate_and_hands_off_the_posterior():
    res = leader_step(uniform_belief(GRID), _z(0), 0, LAYOUT, P, step=4, previous=None)
    assert res.next_leader in LAYOUT.neighbours[0]
    assert res.scores.shape == res.candidates.shape and np.all(res.scores >= 0)
    assert res.next_leader == res.candidates[np.argmax(res.scores)]
    h, why = receive_handoff(res.payload, GRID, LAYOUT.n, receiver=res.next_leader)
    assert why is None and h.step == 4 and h.sender == 0
    np.testing.assert_array_equal(h.idx, res.belief.idx)
    np.testing.assert_allclose(estimate(h.belief()).mean, res.estimate.mean, atol=1e-4)


def test_triplet_rule_in_leader_step():
    nb = LAYOUT.neighbours[1]
    for prev in nb:
        res = leader_step(uniform_belief(GRID), _z(1), 1, LAYOUT, P, step=0, previous=int(prev))
        assert res.next_leader != prev and prev not in res.candidates
        assert res.neighbourhood_size == res.candidates.size >= 2  # Table 4's |N|, after the rule


def test_selection_rules():
    post, _ = update(uniform_belief(GRID), _z(3), POS[3], True, P)
    post, _ = update(post, _z(0), POS[0], False, P)
    k, cands, _ = select_next(post, LAYOUT, 1, None, P, 'nearest')
    centre = estimate(post).mean
    assert k == cands[np.argmin(np.linalg.norm(POS[cands] - centre, axis=1))]
    rng = np.random.default_rng(0)
    picks = {select_next(post, LAYOUT, 1, None, P, 'random', rng)[0] for _ in range(60)}
    assert picks == set(LAYOUT.neighbours[1].tolist())
    with pytest.raises(ValueError, match='rng'):
        select_next(post, LAYOUT, 1, None, P, 'random')
    with pytest.raises(ValueError, match='selection'):
        select_next(post, LAYOUT, 1, None, P, 'best')


def test_centralized_fusion_localises_the_target():
    zs = np.array([_z(k) for k in range(LAYOUT.n)])
    b = uniform_belief(GRID)
    for _ in range(3):
        b, e = centralized_step(b, zs, LAYOUT, P)
    assert np.linalg.norm(e.mean - TRUTH) < 8.0
    with pytest.raises(ValueError, match='zs'):
        centralized_step(b, zs[:3], LAYOUT, P)

import numpy as np
import pytest

from track_core.idsq.network import SensorLayout, build_neighbours, candidates, handoff_targets, start_leader
from track_core.idsq.simulation import Scenario


def test_neighbours_within_range_or_two_nearest():
    pos = np.array([[0, 0], [30, 0], [0, 35], [100, 0], [150, 0], [300, 300]], float)
    nb = build_neighbours(pos, 40.0, 2)
    np.testing.assert_array_equal(nb[0], [1, 2])          # two in range
    np.testing.assert_array_equal(nb[1], [0, 2])          # 0 at 30 m, 2 at 46 m > 40: fewer than 2 → two nearest
    np.testing.assert_array_equal(nb[3], [1, 4])          # none in range → two nearest (70 m, 50 m)
    np.testing.assert_array_equal(nb[5], [3, 4])
    assert all(k not in nb[k] for k in range(len(pos)))


def test_many_in_range_are_all_kept():
    pos = np.array([[0, 0], [10, 0], [0, 10], [-10, 0], [0, -10]], float)
    assert build_neighbours(pos)[0].size == 4


def test_triplet_rule_excludes_previous_leader():
    lay = SensorLayout(np.array([[0, 0], [30, 0], [0, 30], [20, 20]], float), np.zeros(4, bool))
    assert 1 in lay.neighbours[0]
    c = candidates(lay, 0, previous=1)
    assert 1 not in c and c.size == lay.neighbours[0].size - 1
    np.testing.assert_array_equal(candidates(lay, 0, None), lay.neighbours[0])


def test_triplet_rule_then_two_nearest():
    # sensor 0 has exactly two sensors in range (1 and 2); 3 is the next nearest (45 m).
    pos = np.array([[0, 0], [30, 0], [0, 35], [45, 0], [200, 200]], float)
    lay = SensorLayout(pos, np.zeros(5, bool))
    np.testing.assert_array_equal(lay.neighbours[0], [1, 2])
    # previous leader 1 excluded first, then "fewer than two in range → the two nearest" of the rest
    np.testing.assert_array_equal(candidates(lay, 0, previous=1), [2, 3])
    np.testing.assert_array_equal(candidates(lay, 0, previous=2), [1, 3])
    # a sensor with none in range: the two nearest other than the previous leader
    np.testing.assert_array_equal(candidates(lay, 4, previous=3), [1, 2])


def test_triplet_rule_with_only_the_previous_leader_left_allows_it_back():
    lay = SensorLayout(np.array([[0, 0], [10, 0]], float), np.zeros(2, bool), min_neighbours=1)
    np.testing.assert_array_equal(candidates(lay, 0, previous=1), [1])


def test_sparse_field_leaders_keep_a_choice():
    """K = 24 without jitter: every sensor has exactly two neighbours, and after the triplet rule
    a leader still chooses between two (Table 4: avg. neigh. size 2.0 at K = 24)."""
    lay = Scenario(n_sensors=24, jitter_var=0.0).layout(np.random.default_rng(0))
    assert all(nb.size == 2 for nb in lay.neighbours)
    for k in range(lay.n):
        for prev in lay.neighbours[k]:
            c = candidates(lay, k, int(prev))
            assert c.size == 2 and prev not in c and k not in c


def test_start_leader_is_loudest_acoustic_sensor():
    lay = SensorLayout(np.zeros((4, 2)) + np.arange(4)[:, None], np.array([True, False, False, True]))
    assert start_leader(lay, np.array([9.0, 1.0, 2.0, 8.0])) == 2   # DOA sensors 0, 3 are skipped
    all_doa = SensorLayout(lay.positions, np.ones(4, bool))
    assert start_leader(all_doa, np.array([9.0, 1.0, 2.0, 8.0])) == 0


def test_bad_layout_raises():
    with pytest.raises(ValueError, match='positions'):
        SensorLayout(np.zeros((3, 3)), np.zeros(3, bool))
    with pytest.raises(ValueError, match='comm_range'):
        SensorLayout(np.zeros((3, 2)), np.zeros(3, bool), comm_range=-1.0)


def test_handoff_targets_is_the_union_of_candidates_over_every_previous_leader():
    """The closed form (same rule with min_neighbours + 1) equals the brute-force union, ties included."""
    rng = np.random.default_rng(5)
    for trial in range(60):
        k = int(rng.integers(3, 20))
        pos = rng.uniform(0, rng.uniform(30, 200), (k, 2))
        if trial % 3 == 0:
            pos = np.round(pos / 20) * 20  # equal distances
        lay = SensorLayout(pos, np.zeros(k, bool), float(rng.uniform(10, 60)), int(rng.integers(1, min(3, k - 1) + 1)))
        for j in range(k):
            brute = set(lay.neighbours[j].tolist())
            for p in range(k):
                brute.update(candidates(lay, j, p).tolist())
            assert handoff_targets(lay, j).tolist() == sorted(brute)

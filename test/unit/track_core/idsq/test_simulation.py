import numpy as np
import pytest

from track_core.idsq.simulation import Scenario, draw_run, run_centralized, run_idsq, start, summary


def test_layout_truth_and_doa_fraction():
    sc = Scenario(n_sensors=40, doa_fraction=0.3)
    d = draw_run(sc, np.random.SeedSequence(1))
    assert d.layout.positions.shape == (40, 2) and d.layout.is_doa.sum() == 12
    # jitter N(0, 25) around a 10 × 4 grid of block centres
    gx = (np.arange(4) + 0.5) * 37.5
    gy = (np.arange(10) + 0.5) * 25.0
    base = np.stack(np.meshgrid(gx, gy), axis=-1).reshape(-1, 2)
    dev = d.layout.positions - base
    assert abs(dev.std() - 5.0) < 4 * 5.0 / np.sqrt(2 * dev.size)
    assert sc.n_steps == 72 and np.allclose(d.truth[:, 0], 75.0) and np.allclose(np.diff(d.truth[:, 1]), 3.5)
    assert not d.layout.is_doa[start(sc, d)]


def test_runs_are_reproducible_and_track_the_vehicle():
    sc = Scenario(n_sensors=48, doa_fraction=0.3)
    seeds = np.random.SeedSequence(3).spawn(3)
    res = [run_idsq(sc, draw_run(sc, s)) for s in seeds]
    again = run_idsq(sc, draw_run(sc, seeds[0]))
    np.testing.assert_array_equal(again.estimates, res[0].estimates)
    s = summary(res)
    assert s['mmse_error_m'] < 30.0  # the paper's K = 48 is 14.3 m; uniform start is ~75 m
    assert 2.0 <= s['neighborhood_size'] <= 8.0
    assert s['bytes_per_step'] == pytest.approx(46 + 8 * s['belief_size'])


def test_centralized_is_far_more_accurate_on_the_same_run():
    sc = Scenario(n_sensors=32, doa_fraction=0.3)
    d = draw_run(sc, np.random.SeedSequence(5))
    c, m = run_centralized(sc, d), run_idsq(sc, d)
    assert c.error[5:].mean() < 8.0 and c.error[5:].mean() < m.error[5:].mean()


def test_bad_scenario_raises():
    with pytest.raises(ValueError, match='n_sensors'):
        Scenario(n_sensors=30)
    with pytest.raises(ValueError, match='doa_fraction'):
        Scenario(doa_fraction=1.5)

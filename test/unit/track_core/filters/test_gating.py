"""InnovationGate: the χ² threshold, the Cholesky distance, and a gate that never locks a track out."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import chi2

from track_core.demo import CVKalmanTracker
from track_core.filters.gating import InnovationGate, gate_threshold, innovation_d2


def test_threshold_and_distance():
    assert gate_threshold(0.9999, 2) == pytest.approx(chi2.ppf(0.9999, 2)) == pytest.approx(18.42, abs=0.01)
    S = np.array([[4.0, 1.0], [1.0, 3.0]])
    nu = np.array([1.0, -2.0])
    assert innovation_d2(nu, S) == pytest.approx(nu @ np.linalg.solve(S, nu))
    assert innovation_d2(nu, -S) == math.inf
    with pytest.raises(ValueError):
        gate_threshold(1.0, 2)


def _tracked(n: int = 10) -> CVKalmanTracker:
    trk = CVKalmanTracker()
    for k in range(n):
        trk.update(0.1 * k, np.array([0.1 * k, 0.0]), np.eye(2))
    return trk


def test_an_outlier_is_refused_and_leaves_the_track_alone():
    trk, gate = _tracked(), InnovationGate()
    x = trk.x.copy()
    decision, xo, _ = trk.update_gated(1.0, np.array([1000.0, 0.0]), np.eye(2), gate)
    assert not decision.accepted and xo is None and np.array_equal(trk.x, x)
    assert 'innovation gate' in decision.reason()
    decision, xo, _ = trk.update_gated(1.0, np.array([1.0, 0.0]), np.eye(2), gate)
    assert decision.accepted and xo is not None and gate.misses == 0


def test_a_lost_track_starts_again_after_max_misses_or_a_long_gap():
    trk, gate = _tracked(), InnovationGate(max_misses=3, max_gap=5.0)
    far = np.array([500.0, 500.0])
    outcomes = [trk.update_gated(1.0 + 0.1 * k, far, np.eye(2), gate)[0] for k in range(3)]
    assert [d.accepted for d in outcomes] == [False, False, True] and outcomes[-1].reinitialise
    assert np.allclose(trk.x[[0, 2]], far)  # the new track starts at the report
    decision, _, _ = _tracked().update_gated(100.0, np.array([-900.0, 0.0]), np.eye(2), gate)
    assert decision.accepted and decision.reinitialise


def test_persistent_rejections_are_noticed_but_an_honest_source_keeps_the_track():
    trk, gate = _tracked(), InnovationGate(window=10)
    for k in range(20):  # honest and rogue interleaved: the rogue never takes the track over
        t = 1.0 + 0.1 * k
        assert trk.update_gated(t, np.array([t, 0.0]), np.eye(2), gate)[0].accepted
        assert not trk.update_gated(t + 0.05, np.array([t + 1000.0, 0.0]), np.eye(2), gate)[0].accepted
    assert gate.persistent and gate.rejected_share == pytest.approx(0.5)
    gate.reset()
    assert not gate.persistent and gate.misses == 0


def test_a_fast_rogue_cannot_take_the_track_over_while_the_honest_source_keeps_coming():
    """Ten rogue reports between two honest ones are ten misses in a row; with ``lost_time`` they are no
    evidence that the track is lost, because an honest report came less than ``lost_time`` ago."""
    for lost_time, hijacked in ((0.0, True), (2.0, False)):
        trk, gate = _tracked(), InnovationGate(max_misses=10, lost_time=lost_time)
        taken = False
        for k in range(30):
            t = 1.0 + 0.1 * k
            taken |= not trk.update_gated(t, np.array([t, 0.0]), np.eye(2), gate)[0].accepted
            for j in range(10):  # a rogue at 100 Hz, 1000 m off
                d = trk.update_gated(t + 0.005 + 0.0095 * j, np.array([1000.0, 0.0]), np.eye(2), gate)[0]
                taken |= d.reinitialise
        assert taken is hijacked


def test_a_target_that_really_jumped_is_found_again_after_lost_time():
    trk, gate = _tracked(), InnovationGate(max_misses=10, lost_time=2.0)
    decisions = [trk.update_gated(2.0 + 0.1 * k, np.array([1000.0, 0.0]), np.eye(2), gate)[0] for k in range(40)]
    first = next(k for k, d in enumerate(decisions) if d.reinitialise)
    assert all(not d.accepted for d in decisions[:first])
    assert (2.0 + 0.1 * first) - 0.9 >= 2.0 - 1e-9  # not before lost_time after the last accepted report (0.9 s)
    assert np.allclose(trk.x[[0, 2]], [1000.0, 0.0], atol=5.0)

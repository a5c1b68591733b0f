"""The observer's timing (``contacts.ContactSequencer``): contacts at any times, predict-only steps through
gaps, navigation interpolated and waited for, refusals that change nothing, and the paper's closed loop
unchanged when the contacts come every period."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from track_core.sonar import Scenario, SensorMode, SonarParams, make_tracker
from track_core.sonar.contacts import (
    Contact,
    ContactSequencer,
    Dropped,
    Fix,
    Step,
    bearing_of_yaw,
    paper_reading,
    simulated_contact,
    yaw_of_bearing,
)

S = 10**9  # ns per s
T = 1.0
PARAMS = SonarParams(T=T)
X0 = np.array([300.0, 12.25, 300.0, -12.25])


def _tracker(seed: int = 1):
    trk = make_tracker('ss-pf', PARAMS, np.random.default_rng(seed), delta=50.0)
    trk.initialize(X0, Scenario(params=PARAMS).prior_cov)
    return trk


def _seq(seed: int = 1, **kw) -> ContactSequencer:
    args = {'nav_wait_ns': 2 * S, 'nav_max_age_ns': 3 * S} | kw
    return ContactSequencer(_tracker(seed), round(T * S), **args)


def _fix(t: float, xy=(0.0, 0.0), vel=(10.0, 0.0), heading=0.0) -> Fix:
    return Fix(round(t * S), np.array(xy, float), np.array(vel, float), heading)


def _truth(t: float) -> np.ndarray:
    return X0 + t * np.array([0.0, 0.0, 0.0, 0.0]) + np.array([X0[1] * t, 0.0, X0[3] * t, 0.0])


def _contact(rng, t: float, mode=SensorMode.PASSIVE, obs=(0.0, 0.0)) -> Contact:
    return simulated_contact(rng, round(t * S), _truth(t), np.array(obs, float), mode, PARAMS)


def _steps(results) -> list[Step]:
    return [r for r in results if isinstance(r, Step)]


def test_bearing_and_yaw_are_each_others_inverse_across_the_circle():
    b = np.linspace(-math.pi + 1e-9, math.pi, 101)
    np.testing.assert_allclose(bearing_of_yaw(yaw_of_bearing(b)), b, atol=1e-12)
    assert bearing_of_yaw(0.0) == pytest.approx(math.pi / 2)  # REP-103 east is the paper's 90°


def test_contacts_every_period_are_the_papers_steps_bit_for_bit():
    """Contacts on the k·T grid, navigation at each: the same estimates as calling the SS-PF directly."""
    rng_a, rng_b = np.random.default_rng(5), np.random.default_rng(5)
    seq, ref = _seq(), _tracker()
    for k in range(1, 16):
        obs = (10.0 * k, 0.0)
        mode = seq.tracker.next_mode
        c = _contact(rng_a, k, mode, obs)
        got = _steps(seq.add_contact(c, now=k * S) + seq.add_fix(_fix(k, obs), now=k * S))
        c_ref = _contact(rng_b, k, ref.next_mode, obs)
        est = ref.step(paper_reading(c_ref), ref.next_mode, np.array(obs), R=c_ref.R)
        assert len(got) == 1 and got[0].key == k * S
        np.testing.assert_array_equal(got[0].estimate.mean, est.mean)
        np.testing.assert_array_equal(got[0].estimate.cov, est.cov)
    assert seq.predictions == 0 and seq.updates == 15


def test_a_gap_is_predicted_through_one_period_at_a_time_and_counted():
    rng = np.random.default_rng(2)
    seq = _seq()
    seq.add_fix(_fix(0.0), 0)
    out = []
    for t in (1.0, 1.7, 2.9, 13.2, 13.9):  # irregular, and a 10.3 s gap
        seq.add_fix(_fix(t, (10.0 * t, 0.0)), round(t * S))
        out += _steps(seq.add_contact(_contact(rng, t, seq.tracker.next_mode, (10.0 * t, 0.0)), round(t * S)))
    keys = [s.key / S for s in out]
    predicted = [s.key / S for s in out if s.contact is None]
    assert predicted == pytest.approx([3.9, 4.9, 5.9, 6.9, 7.9, 8.9, 9.9, 10.9, 11.9])
    assert keys == sorted(keys) and len(out) == 5 + 9 and seq.predictions == 9
    spread = [np.trace(s.estimate.cov[np.ix_([0, 2], [0, 2])]) for s in out]
    assert all(b > a for a, b in itertools.pairwise(spread[2:12]))  # grows through the gap


def test_coasting_takes_the_same_steps_as_waiting_for_the_next_contact():
    """A stopped sensor: ``tick`` predicts on the node clock; the later contact gives the same estimate as
    a replay that takes the predict-only steps only when that contact comes."""
    def run(coast: bool):
        rng = np.random.default_rng(3)
        seq = _seq(coast_after_ns=S // 2 if coast else 0)
        for t in (1.0, 2.0):
            seq.add_fix(_fix(t), round(t * S))
            seq.add_contact(_contact(rng, t, seq.tracker.next_mode), round(t * S))
        ticked = []
        for now in np.arange(2.0, 8.0, 0.1):
            ticked += _steps(seq.tick(round(now * S)))
        seq.add_fix(_fix(8.0), 8 * S)  # the same reading in both runs (a sonar that obeyed no new request)
        last = _steps(seq.add_contact(_contact(rng, 8.0, SensorMode.ACTIVE), 8 * S))
        return ticked, last, seq
    ticked, last_c, seq_c = run(True)
    waited, last_w, seq_w = run(False)
    assert [s.key for s in ticked] == [3 * S, 4 * S, 5 * S, 6 * S, 7 * S] and waited == []
    assert [s.key for s in last_w] == [3 * S, 4 * S, 5 * S, 6 * S, 7 * S, 8 * S] and len(last_c) == 1
    np.testing.assert_array_equal(last_c[-1].estimate.mean, last_w[-1].estimate.mean)
    assert seq_c.predictions == seq_w.predictions == 5


def test_a_contact_waits_for_the_fix_after_it_then_is_interpolated():
    rng = np.random.default_rng(4)
    seq = _seq()
    seq.add_fix(_fix(0.5, (0.0, 0.0)), 0)
    c = _contact(rng, 1.0)
    assert seq.add_contact(c, S) == [] and len(seq.held) == 1  # the fix after it has not come
    (step,) = _steps(seq.add_fix(_fix(1.5, (10.0, 20.0)), S))
    np.testing.assert_allclose(step.observer_xy, [5.0, 10.0])


def test_without_navigation_the_contact_is_extrapolated_or_dropped_with_a_reason():
    rng = np.random.default_rng(4)
    seq = _seq(nav_max_age_ns=S)
    seq.add_fix(_fix(0.5, (0.0, 0.0), vel=(2.0, -4.0)), 0)
    seq.add_contact(_contact(rng, 1.0), S)
    (step,) = _steps(seq.tick(3 * S + 1))  # nav_wait (2 s) over: extrapolated 0.5 s with the velocity
    np.testing.assert_allclose(step.observer_xy, [1.0, -2.0])
    seq.add_contact(_contact(rng, 3.0), 3 * S)
    (dropped,) = seq.tick(6 * S)
    assert isinstance(dropped, Dropped) and 'navigation fix is 2.5 s before' in dropped.reason


def test_late_duplicate_and_excess_contacts_are_refused_and_change_nothing():
    rng = np.random.default_rng(6)
    seq = _seq(max_held=2)
    seq.add_fix(_fix(2.0), 0)
    seq.add_contact(_contact(rng, 2.0), 2 * S)
    state = (seq.key, seq.tracker.particles.copy(), seq.updates)
    assert 'not after the filter time' in seq.contact_problem(_contact(rng, 1.5))
    assert 'not after the filter time' in seq.contact_problem(_contact(rng, 2.0))
    seq.add_contact(_contact(rng, 3.0), 3 * S)  # held: no fix after it yet
    assert 'already waiting' in seq.contact_problem(_contact(rng, 3.0))
    seq.add_contact(_contact(rng, 4.0), 3 * S)
    assert 'already waiting for navigation' in seq.contact_problem(_contact(rng, 5.0))
    assert seq.key == state[0] and seq.updates == state[2]
    np.testing.assert_array_equal(seq.tracker.particles, state[1])
    assert 'not after the last fix' in seq.nav.problem(_fix(1.0))


def test_a_relative_contact_is_turned_by_the_ships_heading():
    rng_w, rng_r = np.random.default_rng(8), np.random.default_rng(8)
    heading = math.radians(35.0)
    world = simulated_contact(rng_w, S, _truth(1.0), np.zeros(2), SensorMode.ACTIVE, PARAMS)
    rel = simulated_contact(rng_r, S, _truth(1.0), np.zeros(2), SensorMode.ACTIVE, PARAMS, heading=heading)
    assert rel.relative and not world.relative
    np.testing.assert_allclose(paper_reading(rel, heading), paper_reading(world), atol=1e-12)


def test_an_interval_a_few_nanoseconds_off_the_period_is_the_period():
    """Stamps made as origin + k·T in float seconds jitter by nanoseconds: eqs. 3-4 of T are used."""
    rng_a, rng_b = np.random.default_rng(9), np.random.default_rng(9)
    a, b = _seq(), _seq()
    for k, jitter in ((1, 0), (2, 3), (3, -2)):
        for seq, rng, key in ((a, rng_a, k * S), (b, rng_b, k * S + jitter)):
            seq.add_fix(Fix(key, np.zeros(2), np.zeros(2), 0.0), key)
            c = _contact(rng, k, seq.tracker.next_mode)
            seq.add_contact(Contact(key, c.mode, c.yaw, c.range, c.R), key)
    np.testing.assert_array_equal(a.tracker.estimate.mean, b.tracker.estimate.mean)

"""The sonar pair's lock-step gates (track_core.sonar.lockstep): unit rules, and identity with the old nodes.

``data/lockstep_cases.json``: 140 random sequences of due steps, pings and observer positions for
the smart target, run through the node methods as they were before issue 12 (``smart_target`` at
commit 3ac9344, logger, publishers and the target model stubbed); the expected output is the steps
it took, with what each step was given. The driver below is the new node's callback: the gate must
reproduce every case. (Its observer cases, which fixed the old wall-time TruthGate, went when
issue 19 replaced it by the truth-driven one: the unit rules below and the nodes-equal-the-core
test of test/integration/test_sonar.py hold the new one.)
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from track_core.sonar.lockstep import TargetGate, TruthGate

CASES = json.loads((Path(__file__).parent / 'data/lockstep_cases.json').read_text())


def replay_target(case: dict) -> list:
    gate, out, key = TargetGate(case['sync'], round(2e9 * case['period'])), [], {}
    for ev in case['events']:
        if ev[0] == 'due':
            key[ev[1]] = ev[2]
        if ev[0] == 'ping':
            gate.add_ping(ev[1], np.array(ev[2]))
            continue
        ready = gate.due(ev[1], ev[2]) if ev[0] == 'due' else gate.add_observer(ev[1], np.array(ev[2]))
        out += [[key[t], bool(p), [float(v) for v in xy]] for t, p, xy in ready]
    return out


@pytest.mark.parametrize('i', range(len(CASES['target'])))
def test_target_gate_reproduces_the_old_smart_target(i):
    assert replay_target(CASES['target'][i]) == CASES['target'][i]['out']


def test_the_cases_cover_waiting_pings_and_free_running():
    assert any(o[1] for c in CASES['target'] for o in c['out'])
    assert {c['sync'] for c in CASES['target']} == {True, False}


def test_truth_gate_takes_the_truths_in_grid_order_with_their_own_stamps():
    T = 1_000_000_000
    t1 = 1_796_172_781_123_456_789  # any first stamp: the grid is t1 + (j - 1)·T
    gate = TruthGate(T)
    (j, key, x), = gate.add_truth(t1, np.zeros(4))
    assert (j, key, x.tolist()) == (1, t1, [0.0] * 4) and gate.next == 2
    assert gate.add_truth(t1 + 2 * T + 7, np.full(4, 2.0)) == []           # step 3 waits for step 2
    ready = gate.add_truth(t1 + T - 11, np.ones(4))                         # jitter within T/4 is the grid
    assert [(j, k) for j, k, _ in ready] == [(2, t1 + T - 11), (3, t1 + 2 * T + 7)] and gate.truth == {}


def test_truth_gate_refuses_without_changing_anything():
    T = 500_000_000
    gate = TruthGate(T)
    gate.add_truth(10 * T, np.zeros(4))
    before = (gate.first_key, gate.next, dict(gate.truth))
    assert 'off the step grid' in gate.problem(10 * T + T // 2)
    assert 'already received' in gate.problem(10 * T)
    assert 'ahead' in gate.problem(10 * T + 65 * T)  # step 66 = next (2) + WINDOW
    assert gate.problem(10 * T + 64 * T) is None
    assert (gate.first_key, gate.next, dict(gate.truth)) == before


def test_truth_gate_reports_a_gap_once():
    T = 1000
    gate = TruthGate(T)
    gate.add_truth(T, np.zeros(4))
    for j in (3, 4, 5):
        gate.add_truth(j * T, np.zeros(4))
    assert gate.stalled() == 2 * T and gate.stalled() is None
    assert [j for j, _, _ in gate.add_truth(2 * T, np.zeros(4))] == [2, 3, 4, 5]


def test_target_gate_waits_for_the_observer_of_the_previous_step():
    gate = TargetGate(sync_observer=True, keep_ns=2)
    (t, pinged, xy), = gate.due(1.0, 10)                  # step 1: nothing to wait for
    assert (t, pinged) == (1.0, False) and np.all(xy == 0)
    assert gate.due(2.0, 20) == []
    gate.add_ping(10, np.array([5.0, 6.0]))
    (t, pinged, xy), = gate.add_observer(10, np.array([1.0, 2.0]))
    assert (t, pinged, xy.tolist()) == (2.0, True, [1.0, 2.0])
    assert gate.pings == {} and gate.observer == {}       # older than t_2 − keep: dropped

"""The sonar pair's lock-step gates (track_core.sonar.lockstep): unit rules, and identity with the old nodes.

``data/lockstep_cases.json``: 140 random sequences of due steps and truths for the observer and
140 of due steps, pings and observer positions for the smart target, run through the node methods
as they were before issue 12 (``sonar_observer``/``smart_target`` at commit 3ac9344, logger,
publishers and the target model stubbed); the expected output is the steps they took, with what
each step was given. The drivers below are the new nodes' callbacks: the gates must reproduce every case.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from track_core.sonar.lockstep import TargetGate, TruthGate

CASES = json.loads((Path(__file__).parent / 'data/lockstep_cases.json').read_text())


def replay_observer(case: dict) -> list:
    gate, out = TruthGate(), []
    for ev in case['events']:
        ready = gate.due(ev[1], ev[2]) if ev[0] == 'due' else gate.add_truth(ev[1], np.array(ev[2]))
        out += [['step', t, x.tolist()] for t, x in ready]
        if gate.stalled() is not None:
            out.append(['warn'])
    return out


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


@pytest.mark.parametrize('i', range(len(CASES['observer'])))
def test_truth_gate_reproduces_the_old_observer(i):
    assert replay_observer(CASES['observer'][i]) == CASES['observer'][i]['out']


@pytest.mark.parametrize('i', range(len(CASES['target'])))
def test_target_gate_reproduces_the_old_smart_target(i):
    assert replay_target(CASES['target'][i]) == CASES['target'][i]['out']


def test_the_cases_cover_waiting_pings_and_free_running():
    assert any(o == ['warn'] for c in CASES['observer'] for o in c['out'])
    assert any(o[1] for c in CASES['target'] for o in c['out'])
    assert {c['sync'] for c in CASES['target']} == {True, False}


def test_truth_gate_steps_in_order_when_both_are_there():
    gate = TruthGate()
    assert gate.due(1.0, 1) == [] and gate.due(2.0, 2) == []
    assert gate.add_truth(2, np.ones(4)) == []            # step 1 first
    ready = gate.add_truth(1, np.zeros(4))
    assert [t for t, _ in ready] == [1.0, 2.0] and gate.truth == {}
    assert gate.due(3.0, 3) == [] and gate.stalled() is None
    gate.due(4.0, 4), gate.due(5.0, 5)
    assert gate.stalled() == 3.0 and gate.stalled() is None  # reported once


def test_target_gate_waits_for_the_observer_of_the_previous_step():
    gate = TargetGate(sync_observer=True, keep_ns=2)
    (t, pinged, xy), = gate.due(1.0, 10)                  # step 1: nothing to wait for
    assert (t, pinged) == (1.0, False) and np.all(xy == 0)
    assert gate.due(2.0, 20) == []
    gate.add_ping(10, np.array([5.0, 6.0]))
    (t, pinged, xy), = gate.add_observer(10, np.array([1.0, 2.0]))
    assert (t, pinged, xy.tolist()) == (2.0, True, [1.0, 2.0])
    assert gate.pings == {} and gate.observer == {}       # older than t_2 − keep: dropped

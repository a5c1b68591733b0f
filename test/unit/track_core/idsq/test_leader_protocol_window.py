"""Protocol windows of the IDSQ ledger (issue 13, defect 3): a handoff or a reading whose step is far
from what the sensor expects is refused with a reason, the ledger stays bit-identical (but for its
``refused`` counter), and valid input afterwards still works."""

from __future__ import annotations

import pickle

import numpy as np

from track_core.idsq import GridSpec, Handoff, SimNoise, TrackerParams, encode_handoff
from track_core.idsq.leader_protocol import (
    READING_WINDOW,
    STEP_WINDOW,
    HandoffLedger,
    Led,
    Reply,
    SensorSetup,
    stamp_of_step,
    start_leader_of,
    step_of_stamp,
)
from track_core.idsq.readings import field_readings
from track_core.idsq.simulation import scenario_of

DT = 0.5


def _ledger(me: int, n: int = 8, seed: int = 1):
    _, layout, truth = scenario_of(seed, n, 0.3)
    led = HandoffLedger(SensorSetup(me, layout.positions[me], bool(layout.is_doa[me]), GridSpec.for_field(),
                                    TrackerParams(), seed, 'mi'))
    led.set_layout(layout)
    return led, layout, truth


def _state(led: HandoffLedger) -> bytes:
    """Every field of the ledger but the refusal counter, as bytes (arrays included)."""
    return pickle.dumps({k: v for k, v in vars(led).items() if k not in ('refused', 's', 'layout')})


def _handoff(step: int, sender: int, receiver: int) -> bytes:
    return encode_handoff(Handoff(step, sender, receiver, GridSpec.for_field(), np.array([5, 6]), np.array([0.5, 0.5])))


def _sender_of(layout, me: int) -> int:
    return int(next(j for j in range(layout.n) if me in set(layout.neighbours[j].tolist())))


def test_a_handoff_of_step_0xffffffff_is_refused_and_the_sensor_takes_the_next_one():
    led, layout, truth = _ledger(0)
    sender = _sender_of(layout, 0)
    for s in range(3):
        led.on_field(field_readings(truth[s], layout, s, SimNoise(), 1))
    before = _state(led)
    for step in (0xFFFFFFFF, 2 + STEP_WINDOW + 1, 2**31):
        fx = led.on_handoff(_handoff(step, sender, 0))
        assert fx[-1].sender == sender and fx[-1].step == step and fx[-1].refusal.startswith('window: ')
        assert fx[0].refusal == ('handoff', f'{fx[-1].refusal} (sensor {sender}, step {step})')
    assert _state(led) == before and led.refused == 3 and led.pending is None
    # the real handoff of step 2 is taken and step 3 is led once its reading comes
    assert led.on_handoff(_handoff(2, sender, 0)) == [Reply(sender, 2, None)] and led.pending.step == 3
    fx = led.on_field(field_readings(truth[3], layout, 3, SimNoise(), 1))
    assert any(isinstance(f, Led) and f.step == 3 for f in fx) and led.led == [3]


def test_before_any_reading_a_handoff_within_the_window_is_taken():
    led, layout, _ = _ledger(0)
    sender = _sender_of(layout, 0)
    assert led.horizon() == -1
    assert led.on_handoff(_handoff(STEP_WINDOW + 5, sender, 0))[-1].refusal.startswith('window: ')
    assert led.on_handoff(_handoff(0, sender, 0)) == [Reply(sender, 0, None)]


def test_a_reading_with_an_absurd_stamp_is_refused_and_keeps_the_buffer():
    _, layout, truth = scenario_of(1, 8, 0.3)
    start = start_leader_of(layout, truth[0], SimNoise(), 1)
    led, _, _ = _ledger(start)
    led.on_field(field_readings(truth[0], layout, 0, SimNoise(), 1))
    before = _state(led)
    for t in (2147483647.0, 1e15, stamp_of_step(READING_WINDOW + 1, DT)):
        step = step_of_stamp(t, DT)
        why = led.reading_problem(step, t, DT)
        assert why is not None and why.split(':')[0] in ('step', 'header.stamp'), why
    assert led.reading_problem(None, 0.3, DT).startswith('header.stamp: ')
    assert _state(led) == before
    assert led.reading_problem(1, stamp_of_step(1, DT), DT) is None       # the next real one passes
    assert led.reading_problem(READING_WINDOW, stamp_of_step(READING_WINDOW, DT), DT) is None
    led.on_field(field_readings(truth[1], layout, 1, SimNoise(), 1))
    assert sorted(led.readings) == [0, 1] and led.led == [0]


def test_the_steps_a_sensor_led_are_kept_for_the_last_window_only():
    """A run of days leads a step every dt: the ledger's per-step memory stays within STEP_WINDOW steps."""
    led, layout, truth = _ledger(0)
    sender = _sender_of(layout, 0)
    n = STEP_WINDOW + 40
    for s in range(n):
        led.on_handoff(_handoff(s, sender, 0))
        led.on_field(field_readings(truth[min(s + 1, len(truth) - 1)], layout, s + 1, SimNoise(), 1))
        for out in list(led.outgoing):  # nobody answers: the handoff is given up, as after a timeout
            for receiver in list(led.outgoing[out].order) if out in led.outgoing else []:
                led.timeout(out, receiver)
    assert led.last_led == n  # it led every step
    assert len(led.led) <= STEP_WINDOW + 1 and min(led.led) >= n - STEP_WINDOW
    assert all(len(book) <= STEP_WINDOW + 1 for book in (led.parent, led.sent, led.handed))

"""The IDSQ ledger's per-step memory over a long run: every book of the chain rule (``led``, ``sent``,
``handed``, ``parent``, ``void``) and the reading buffers keep the last ``STEP_WINDOW`` steps only, also when
every lead is revoked (each revoke adds a void step)."""

from __future__ import annotations

import numpy as np

from track_core.idsq import GridSpec, Handoff, SimNoise, TrackerParams, encode_handoff
from track_core.idsq.leader_protocol import MAX_READINGS, STEP_WINDOW, HandoffLedger, SensorSetup
from track_core.idsq.readings import field_readings
from track_core.idsq.simulation import scenario_of


def _handoff(step: int, sender: int, receiver: int) -> bytes:
    return encode_handoff(Handoff(step, sender, receiver, GridSpec.for_field(), np.array([5, 6]), np.array([0.5, 0.5])))


def test_revoked_leads_over_a_long_run_keep_every_book_within_the_window():
    _, layout, truth = scenario_of(1, 8, 0.3)
    led = HandoffLedger(SensorSetup(0, layout.positions[0], bool(layout.is_doa[0]), GridSpec.for_field(),
                                    TrackerParams(), 1, 'mi'))
    led.set_layout(layout)
    sender = int(next(j for j in range(layout.n) if 0 in set(layout.neighbours[j].tolist())))
    n = STEP_WINDOW + 60
    for s in range(n):
        led.on_handoff(_handoff(s, sender, 0))
        led.on_field(field_readings(truth[min(s + 1, len(truth) - 1)], layout, s + 1, SimNoise(), 1))
        assert led.last_led == s + 1
        led.on_revoke(sender, 0, s)  # the sender revokes: the lead of s + 1 is void, its handoff revoked
        assert s + 1 in led.void
        for out in list(led.outgoing):  # nobody answers what is left
            for receiver in list(led.outgoing[out].order) if out in led.outgoing else []:
                led.timeout(out, receiver)
    assert led.revokes > 0 and len(led.void) > STEP_WINDOW // 2  # the void book did fill
    for name in ('led', 'void', 'parent', 'sent', 'handed'):
        book = getattr(led, name)
        assert len(book) <= STEP_WINDOW + 1 and min(book, default=n) >= n - STEP_WINDOW, name
    assert len(led.readings) <= MAX_READINGS and len(led.missed) <= STEP_WINDOW

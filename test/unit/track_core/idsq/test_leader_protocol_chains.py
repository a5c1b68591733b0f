"""``HandoffLedger``'s chain rule (issue 15): a receiver that took a handoff after its sender had
re-selected is revoked, and the revoke follows its chain to the head, which stops leading."""

from __future__ import annotations

import numpy as np

from track_core.idsq import GridSpec, SimNoise, TrackerParams
from track_core.idsq.handoff import decode_revoke, encode_revoke, peek_header
from track_core.idsq.leader_protocol import HandoffLedger, Revoke, Send, SensorSetup, Void, start_leader_of
from track_core.idsq.readings import field_readings
from track_core.idsq.simulation import scenario_of

N, SEED = 8, 1


def _net():
    _, layout, truth = scenario_of(SEED, N, 0.3)
    leds = {}
    for k in range(N):
        led = HandoffLedger(SensorSetup(k, layout.positions[k], bool(layout.is_doa[k]), GridSpec.for_field(),
                                        TrackerParams(), SEED, 'mi'))
        led.set_layout(layout)
        leds[k] = led
    return leds, layout, truth


def _sends(fx):
    return [f for f in fx if isinstance(f, Send)]


def test_revoke_wire_format():
    data = encode_revoke(7, 2, 5)
    assert len(data) == 14 and decode_revoke(data) == (2, 5, 7) and peek_header(data) is None
    assert decode_revoke(b'IDSQ' + bytes(10)) is None and decode_revoke(b'x') is None


def test_a_late_taker_is_revoked_and_its_chain_ends_at_the_head():
    """Start leader S hands step 0 to A; A times out, S re-selects B (acks). A gets the handoff late,
    leads step 1 and hands it to C, who leads step 2 and hands to D. A's late ack makes S revoke A;
    the revoke walks A → C → D; D drops its belief. B's chain is untouched (B's side is not simulated here)."""
    leds, layout, truth = _net()
    s = start_leader_of(layout, truth[0], SimNoise(), SEED)
    for k in range(N):
        leds[k].on_field(field_readings(truth[0], layout, 0, SimNoise(), SEED))
    first = leds[s].outgoing[0]
    a = first.receiver
    late_to_a = [f for f in leds[s].timeout(0, a) if isinstance(f, Send)]
    b = late_to_a[0].receiver
    assert b != a and leds[s].on_reply(0, s, b, 'ack')[0].receiver == b and leds[s].handed[0] == b
    # A gets the handoff it timed out on (replayed after the partition) and leads the void chain
    payload_a = next(iter(leds[s].sent.values()))  # [a, b]
    assert payload_a == [a, b]
    from track_core.idsq.handoff import Handoff, encode_handoff
    fx = leds[a].on_handoff(encode_handoff(Handoff.from_belief(0, s, a, first.belief)))
    assert fx[0].refusal is None  # A acks
    chain, k, step = [a], a, 1
    leds[a].on_field(field_readings(truth[1], layout, 1, SimNoise(), SEED))
    while len(chain) < 3:  # A leads 1 → C leads 2 → D holds the belief of step 3
        out = leds[k].outgoing[step]
        nxt = out.receiver
        h = Handoff.from_belief(step, k, nxt, out.belief)
        assert leds[nxt].on_handoff(encode_handoff(h))[0].refusal is None
        leds[k].on_reply(step, k, nxt, 'ack')
        chain.append(nxt)
        k, step = nxt, step + 1
        if len(chain) < 3:
            leds[k].on_field(field_readings(truth[step], layout, step, SimNoise(), SEED))
    head = chain[-1]
    assert leds[head].pending is not None and leds[head].pending.step == 3
    # the late ack: S revokes A; deliver revokes along the chain
    fx = leds[s].on_reply(0, s, a, 'ack')
    queue = [f for f in fx if isinstance(f, Revoke)]
    assert len(queue) == 1 and queue[0].receiver == a
    voids = []
    while queue:
        r = queue.pop(0)
        fx = leds[r.receiver].on_handoff(r.payload)
        voids += [(r.receiver, f.step) for f in fx if isinstance(f, Void)]
        queue += [f for f in fx if isinstance(f, Revoke)]
    assert voids == [(chain[0], 1), (chain[1], 2), (chain[2], 3)]
    assert leds[head].pending is None and not leds[a].outgoing and leds[a].last_led == -1
    assert leds[s].handed[0] == b and leds[s].revokes == 1  # the kept chain (B's) is not revoked
    # idempotent: the same revoke again changes nothing
    assert leds[a].on_handoff(encode_revoke(0, s, a)) == []


def test_an_ack_of_the_kept_receiver_replayed_late_is_only_logged():
    leds, layout, truth = _net()
    s = start_leader_of(layout, truth[0], SimNoise(), SEED)
    leds[s].on_field(field_readings(truth[0], layout, 0, SimNoise(), SEED))
    a = leds[s].outgoing[0].receiver
    leds[s].on_reply(0, s, a, 'ack')
    late = leds[s].on_reply(0, s, a, 'ack')  # a transient-local replay of the same ack
    assert len(late) == 1 and 'late ack' in late[0].text and leds[s].revokes == 0


def test_a_revoke_from_another_sender_or_for_another_sensor_changes_nothing():
    leds, layout, truth = _net()
    s = start_leader_of(layout, truth[0], SimNoise(), SEED)
    leds[s].on_field(field_readings(truth[0], layout, 0, SimNoise(), SEED))
    a = leds[s].outgoing[0].receiver
    from track_core.idsq.handoff import Handoff, encode_handoff
    leds[a].on_handoff(encode_handoff(Handoff.from_belief(0, s, a, leds[s].outgoing[0].belief)))
    other = next(k for k in range(N) if k not in (s, a))
    assert leds[a].on_handoff(encode_revoke(0, other, a)) == [] and leds[a].pending is not None
    fx = leds[a].on_handoff(encode_revoke(0, s, other))
    assert 'addressed to sensor' in fx[0].text and leds[a].pending is not None
    assert np.isfinite(leds[a].pending.belief.mass).all()


def test_a_handoff_received_after_the_ack_timeout_is_refused_as_expired():
    """(A partition that heals replays old handoffs: refused, nothing changes but the counter.)"""
    leds, layout, truth = _net()
    s = start_leader_of(layout, truth[0], SimNoise(), SEED)
    leds[s].on_field(field_readings(truth[0], layout, 0, SimNoise(), SEED))
    out = leds[s].outgoing[0]
    from track_core.idsq.handoff import Handoff, encode_handoff
    data = encode_handoff(Handoff.from_belief(0, s, out.receiver, out.belief))
    late = leds[out.receiver].on_handoff(data, age=2.5)  # ack_timeout 2 s
    assert late[-1].refusal is not None and late[-1].refusal.startswith('expired: ')
    assert leds[out.receiver].pending is None and leds[out.receiver].refused == 1
    assert leds[out.receiver].on_handoff(data, age=0.003)[0].refusal is None  # in time: taken


def test_a_revoke_that_overtakes_its_handoff_still_ends_the_chain():
    """Revokes have a topic of their own: nothing orders one after the handoff it voids. A revoke that
    comes first cuts nothing; the receiver takes the handoff and acks, and that ack is revoked again."""
    from track_core.idsq.handoff import Handoff

    leds, layout, truth = _net()
    s = start_leader_of(layout, truth[0], SimNoise(), SEED)
    leds[s].on_field(field_readings(truth[0], layout, 0, SimNoise(), SEED))
    first = leds[s].outgoing[0]
    a = first.receiver
    b = _sends(leds[s].timeout(0, a))[0].receiver
    leds[s].on_reply(0, s, b, 'ack')
    assert leds[a].on_revoke(s, a, 0) == [] and leds[a].pending is None  # came first: nothing to cut
    fx = leds[a].on_handoff(Handoff.from_belief(0, s, a, first.belief))  # the typed path: a Handoff
    assert fx[0].refusal is None and leds[a].pending is not None
    again = [f for f in leds[s].on_reply(0, s, a, 'ack') if isinstance(f, Revoke)]
    assert [(r.step, r.receiver) for r in again] == [(0, a)]
    fx = leds[a].on_revoke(s, a, again[0].step)
    assert [f.step for f in fx if isinstance(f, Void)] == [1] and leds[a].pending is None

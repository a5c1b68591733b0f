"""The IDSQ protocol's ``track_msgs`` messages: the topic table, and a bag of the four kinds of topic decoded by
rosbags from the schemas the bag embeds, the handoff's belief arrays included."""

from __future__ import annotations

import numpy as np

from track_msgs_py.records.idsq import IdsqAck, IdsqHandoff, IdsqLeaderEvent, IdsqRevoke
from track_msgs_py.topics import IDSQ_LEADER, TOPICS, idsq_ack_topic, idsq_handoff_topic, idsq_revoke_topic


def test_the_topic_table_names_the_leader_event():
    assert TOPICS[IDSQ_LEADER].msgtype == 'track_msgs/msg/IdsqLeaderEvent'


def _handoff():
    from track_core.idsq import GridSpec, Handoff, TrackerParams, predict, uniform_belief

    b = predict(uniform_belief(GridSpec.for_field()), TrackerParams(prediction='bank'))  # version 3: the joint
    return Handoff.from_belief(6, 3, 5, b)


def _messages() -> dict[str, tuple[str, object]]:
    return {
        idsq_handoff_topic(5): ('IdsqHandoff', IdsqHandoff.from_handoff(1003.5, _handoff()).to_msg()),
        idsq_ack_topic(3): ('IdsqAck', IdsqAck.reply(6, 3, 5, 'busy: already holding step 7', 1003.5).to_msg()),
        idsq_revoke_topic(5): ('IdsqRevoke', IdsqRevoke(6, 3, 5, 1003.5).to_msg()),
        IDSQ_LEADER: ('IdsqLeaderEvent', IdsqLeaderEvent(
            'step', 6, 3, 5, previous=1, z=0.25, updated=True, belief_size=120, spread_m2=310.5,
            candidates=(5, 4), mi_bits=(0.75, 0.5), handoff_bytes=9000, t=1003.5).to_msg()),
    }


def test_a_bag_of_the_idsq_protocol_decodes_with_rosbags_from_its_own_schemas(schema_bag):
    msgs = _messages()
    decoded = {t: ('', m) for t, m in schema_bag({t: (f'track_msgs/msg/{n}', m) for t, (n, m) in msgs.items()}).items()}
    _, h = decoded[idsq_handoff_topic(5)]
    bank = _handoff().motion
    assert (h.version, h.VERSION_BANK, h.step, h.sender, h.receiver) == (3, 3, 6, 3, 5)
    assert h.cells.dtype == np.uint32 and h.mass.dtype == np.float32
    np.testing.assert_array_equal(h.cells, bank.key)
    np.testing.assert_array_equal(h.mass, bank.mass.astype(np.float32))
    assert h.bank_hypotheses == bank.n_hyp and h.header.frame_id == 'map'
    _, ack = decoded[idsq_ack_topic(3)]
    assert (ack.accepted, ack.reason, ack.header.stamp.sec) == (False, 'busy: already holding step 7', 1003)
    _, ev = decoded[IDSQ_LEADER]
    assert (ev.event, ev.STEP, list(ev.candidates), list(ev.mi_bits), ev.failed) == (0, 0, [5, 4], [0.75, 0.5], -1)

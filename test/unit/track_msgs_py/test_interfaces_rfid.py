"""The RFID protocol's ``track_msgs`` messages: the topic table, rclpy round trips, and a bag of the four
topics decoded by rosbags from the schemas the bag embeds."""

from __future__ import annotations

import math

from rclpy.serialization import deserialize_message, serialize_message

from track_core.rfid.protocol import Command, CommandKind, StepResult
from track_msgs_py.records.rfid import RfidCommand, RfidFound, RfidStep, RfidUserStatus
from track_msgs_py.stamps import sec_to_stamp
from track_msgs_py.topics import RFID_COMMAND, RFID_FOUND, RFID_STEP, RFID_USER_STATUS, TOPICS


def test_the_topic_table_names_the_typed_messages():
    for topic, name in ((RFID_COMMAND, 'RfidCommand'), (RFID_STEP, 'RfidStep'), (RFID_FOUND, 'RfidFound'),
                        (RFID_USER_STATUS, 'RfidUserStatus')):
        assert TOPICS[topic].msgtype == f'track_msgs/msg/{name}'


def _messages() -> dict[str, object]:
    cmd = RfidCommand.from_command(Command(CommandKind.TURN, -0.1 - 0.2, seq=3, repeat=True, reason='signal lost'))
    step = RfidStep.from_result(StepResult(CommandKind.MOVE, 2, dphi=-1.0 / 3.0, n_reads=151, n_outliers=2,
                                           dphi_std=0.05, relocks=1), 0.5)
    return {RFID_COMMAND: cmd.to_msg(1.5), RFID_STEP: step.to_msg(1.25),
            RFID_FOUND: RfidFound(9, 5, 3, 4, 2, 0).to_msg(2.0),
            RFID_USER_STATUS: RfidUserStatus(2, 1, 1, 0.5, 0, 9.5, False, 9.5, 0.0, math.pi).to_msg(1.25)}


def test_a_bag_of_the_rfid_topics_decodes_with_rosbags_from_its_own_schemas(schema_bag):
    msgs = _messages()
    decoded = {topic: ('', m) for topic, m in schema_bag({t: (TOPICS[t].msgtype, m) for t, m in msgs.items()}).items()}
    _, cmd = decoded[RFID_COMMAND]
    assert (cmd.seq, cmd.kind, cmd.angle, cmd.repeat, cmd.reason) == (3, cmd.TURN, -0.1 - 0.2, True, 'signal lost')
    assert cmd.header.stamp.sec == 1 and cmd.header.stamp.nanosec == 500_000_000
    _, step = decoded[RFID_STEP]
    assert (step.kind, step.dphi, step.dphi_known, step.dphi_std, step.dphi_std_known) == (step.MOVE, -1.0 / 3.0,
                                                                                          True, 0.05, True)
    _, status = decoded[RFID_USER_STATUS]
    assert status.header.frame_id == 'map' and status.heading == math.pi


def test_rclpy_round_trip_keeps_every_field():
    for msg in _messages().values():
        assert deserialize_message(serialize_message(msg), type(msg)) == msg
    assert _messages()[RFID_FOUND].header.stamp == sec_to_stamp(2.0)

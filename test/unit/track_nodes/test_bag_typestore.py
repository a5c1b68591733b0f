"""bag.typestore: the bag tools know track_msgs (the recorder writes its schemas, the frame check and the
summary read it back), shown on a small bag of the RFID protocol's topics."""

from __future__ import annotations

import math

from rclpy.serialization import serialize_message
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from track_core.rfid.protocol import Command, CommandKind, StepResult
from track_msgs_py.records.rfid import RfidCommand, RfidFound, RfidStep, RfidUserStatus
from track_msgs_py.tf import TF, planar_transform, tf_message
from track_msgs_py.topics import RFID_COMMAND, RFID_FOUND, RFID_STEP, RFID_USER_STATUS, TOPICS
from track_nodes.bag.frames import check_frames
from track_nodes.bag.typestore import our_types, typestore
from track_nodes.report.rfid import rfid_metrics

RFID = (RFID_COMMAND, RFID_STEP, RFID_FOUND, RFID_USER_STATUS)


def test_the_store_knows_every_track_msgs_type_and_the_standard_ones():
    ts = typestore()
    for topic in RFID:
        msgtype = TOPICS[topic].msgtype
        assert msgtype in our_types()
        text, _ = ts.generate_msgdef(msgtype, ros_version=2)   # what the recorder embeds in the bag
        assert 'uint32 seq' in text
    assert 'nav_msgs/msg/Odometry' in ts.fielddefs
    assert 'track_msgs/msg/RfidStep' not in get_typestore(Stores.ROS2_JAZZY).fielddefs  # the reason it exists


def _search_bag(path) -> None:
    ts = typestore()
    cmds = [Command(CommandKind.MOVE, seq=1), Command(CommandKind.TURN, 0.4, seq=2),
            Command(CommandKind.MOVE, seq=3, repeat=True, reason='signal lost'),
            Command(CommandKind.DONE, seq=4, reason='tag found')]
    msgs = [(TF, tf_message([planar_transform(0.0, 'map', 'rfid_user', 1.0, 0.0, math.pi)]))]
    for k, cmd in enumerate(cmds):
        t = 1.0 + k
        msgs.append((RFID_COMMAND, RfidCommand.from_command(cmd).to_msg(t)))
        msgs.append((RFID_COMMAND, RfidCommand.from_command(cmd).to_msg(t)))  # a re-sent copy: not a new command
        msgs.append((RFID_STEP, RfidStep.from_result(StepResult(cmd.kind, cmd.seq, n_reads=5), 0.5).to_msg(t + 0.5)))
        msgs.append((RFID_USER_STATUS, RfidUserStatus(cmd.seq, 2, 1, 1.25, 0, 0.1, k == 3, 0.1, 0.0,
                                                      0.0).to_msg(0.0)))
    msgs.append((RFID_FOUND, RfidFound(3, 2, 1, 1, 0, 0).to_msg(4.0)))
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        conns = {}
        for k, (topic, msg) in enumerate(msgs):
            if topic not in conns:
                conns[topic] = w.add_connection(topic, TOPICS[topic].msgtype, typestore=ts)
            w.write(conns[topic], 1_000 + k, serialize_message(msg))


def test_frames_and_summary_read_a_bag_of_the_rfid_protocol(tmp_path):
    _search_bag(tmp_path / 'rfid')
    assert check_frames(tmp_path / 'rfid') == []  # the user status is in map; the protocol has no frame
    lines = rfid_metrics(tmp_path / 'rfid')
    assert lines[0] == 'rfid: tag FOUND', lines
    assert 'steps 2, turns 1, distance walked 1.25 m' in lines[1]
    assert 'commands 4 (MOVE 2, TURN 1), repeated steps 1' in lines[2], lines

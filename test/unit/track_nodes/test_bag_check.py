"""check_bag / track-bag-check (issue 19): a bag of the layouts before issue 19 fails, one of ours passes."""

from __future__ import annotations

import numpy as np
from rclpy.serialization import serialize_message
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore
from std_msgs.msg import String

from track_msgs_py.clouds import scan_to_pointcloud2, table_to_pointcloud2
from track_msgs_py.odometry import cv_state_to_odometry
from track_nodes.bag.check import check_bag, main


def _bag(path, messages):
    """``messages``: (topic, type name, message) in order, one nanosecond apart."""
    ts = get_typestore(Stores.ROS2_JAZZY)
    conns = {}
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        for i, (topic, msgtype, msg) in enumerate(messages):
            if topic not in conns:
                conns[topic] = w.add_connection(topic, msgtype, typestore=ts)
            w.write(conns[topic], 1_000 + i, serialize_message(msg))


def _old_odometry(k: int):
    msg = cv_state_to_odometry(float(k), np.array([k, 1.0, 0.0, 0.0]), np.diag([4.0, 1.0, 4.0, 1.0]), 'map', 't')
    c = np.asarray(msg.pose.covariance).reshape(6, 6).copy()
    c[2, 2] = c[3, 3] = c[4, 4] = 1e6  # what _embed_xy wrote before issue 19
    msg.pose.covariance = c.reshape(36)
    return msg


def test_old_layouts_fail_and_ours_pass(tmp_path, capsys):
    ones = np.ones(2)
    new = [('/slam/scan', 'sensor_msgs/msg/PointCloud2', scan_to_pointcloud2(1.0, np.ones((2, 2)))),
           ('/demo/track', 'nav_msgs/msg/Odometry',
            cv_state_to_odometry(1.0, np.zeros(4), np.diag([4.0, 1.0, 4.0, 1.0]), 'map', 't')),
           ('/note', 'std_msgs/msg/String', String(data='not checked'))]
    _bag(tmp_path / 'new', new)
    res = check_bag(tmp_path / 'new')
    assert res.ok and res.problems == [] and dict(res.checked) == {'/slam/scan': 1, '/demo/track': 1}

    old = [*new, ('/slam/scan', 'sensor_msgs/msg/PointCloud2',
                  table_to_pointcloud2(2.0, 'laser', {'range': ones, 'bearing': ones, 'diameter': ones})),
           *[('/demo/track', 'nav_msgs/msg/Odometry', _old_odometry(k)) for k in (2, 3)]]
    _bag(tmp_path / 'old', old)
    res = check_bag(tmp_path / 'old')
    assert not res.ok and dict(res.bad) == {'/slam/scan': 1, '/demo/track': 2}
    assert res.problems[0].startswith('/demo/track: 2 of 3 messages: pose.covariance: z variance 1e+06')
    assert res.problems[1].startswith('/slam/scan: 1 of 2 messages: fields: no x')

    assert main([str(tmp_path / 'new'), str(tmp_path / 'old')]) == 1
    out = capsys.readouterr().out.splitlines()
    assert out[0].endswith('/new: ok: 2 messages on 2 topics checked')
    assert out[1].endswith('/old: FAILED: 5 messages on 2 topics checked') and len(out) == 4
    assert main([str(tmp_path / 'no_such')]) == 1 and 'no such bag' in capsys.readouterr().err


def test_a_flipped_bit_in_any_chunk_is_one_line_and_a_failure(tmp_path, capsys, flip_bit):
    """Every chunk's CRC is checked, also of a chunk that holds no type the check reads."""
    from track_nodes.bag.typestore import typestore
    from track_nodes.bag.writer import BagWriter

    w = BagWriter(tmp_path / 'b').open()
    conn = w.add_connection('/note', 'std_msgs/msg/String', typestore=typestore())
    w.write(conn, 1_000, serialize_message(String(data='not checked, but in a chunk')))
    w.close()
    assert main([str(tmp_path / 'b')]) == 0
    capsys.readouterr()
    offset = flip_bit(tmp_path / 'b' / 'b.mcap')
    assert main([str(tmp_path / 'b')]) == 1
    out, err = capsys.readouterr()
    assert out == '' and len(err.strip().splitlines()) == 1 and f'chunk 1 at byte {offset}' in err, err
    assert 'CRC' in err and 'Traceback' not in err

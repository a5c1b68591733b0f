"""track_nodes.bag.frames: the frame check of a bag, on small bags written here."""

from __future__ import annotations

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PointStamped
from nav_msgs.msg import Odometry
from rclpy.serialization import serialize_message
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore
from visualization_msgs.msg import Marker, MarkerArray

from track_msgs_py.tf import TF, TF_STATIC, planar_transform, tf_message
from track_msgs_py.topics import SLAM_POSE, SONAR_ESTIMATE
from track_nodes.bag.frames import check_frames, main, read_frame_tree

TYPES = {TF: 'tf2_msgs/msg/TFMessage', TF_STATIC: 'tf2_msgs/msg/TFMessage', '/p': 'geometry_msgs/msg/PointStamped',
         SLAM_POSE: 'nav_msgs/msg/Odometry', SONAR_ESTIMATE: 'nav_msgs/msg/Odometry',
         '/tracks': 'nav_msgs/msg/Odometry', '/diag': 'diagnostic_msgs/msg/DiagnosticArray',
         '/markers': 'visualization_msgs/msg/MarkerArray'}


def _point(frame: str) -> PointStamped:
    m = PointStamped()
    m.header.frame_id = frame
    return m


def _odom(frame: str, child: str) -> Odometry:
    m = Odometry(child_frame_id=child)
    m.header.frame_id = frame
    return m


def _write(path, messages) -> None:
    ts = get_typestore(Stores.ROS2_JAZZY)
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        conns = {}
        for k, (topic, msg) in enumerate(messages):
            if topic not in conns:
                conns[topic] = w.add_connection(topic, TYPES[topic], typestore=ts)
            w.write(conns[topic], k + 1, serialize_message(msg))


def _good() -> list:
    return [
        (TF_STATIC, tf_message([planar_transform(0.0, 'map', 'gps', 1.0, 2.0, 0.0),
                                planar_transform(0.0, 'laser', 'base_link', -3.78, -0.5, 0.0)])),
        (TF, tf_message([planar_transform(1.0, 'map', 'laser', 1.0, 2.0, 0.3)])),
        ('/p', _point('base_link')), ('/p', _point('gps')),
        (SLAM_POSE, _odom('map', 'laser')),                    # a body frame
        (SONAR_ESTIMATE, _odom('map', 'sonar_track')),         # a track id: not a frame
        ('/tracks', _odom('map', 'radar/t0+patrol/t0')),         # a track id made a valid tf2 id
        ('/diag', DiagnosticArray()),                          # no frame: allowed here
        ('/markers', MarkerArray(markers=[Marker(header=_point('laser').header)])),
    ]


def test_a_bag_whose_frames_are_all_placed_has_no_problem(tmp_path, capsys):
    _write(tmp_path / 'good', _good())
    tree = read_frame_tree(tmp_path / 'good')
    assert tree.chain('base_link') == ['base_link', 'laser', 'map']
    assert set(tree.used) == {'map', 'base_link', 'gps', 'laser'}  # no track id among them
    assert check_frames(tmp_path / 'good') == []
    assert main([str(tmp_path / 'good')]) == 0
    assert 'every frame is placed' in capsys.readouterr().out


def test_every_kind_of_unplaced_or_invalid_frame_is_reported(tmp_path, capsys):
    bad = [(topic, msg) for topic, msg in _good() if topic != TF]  # laser (and base_link) are not placed now
    bad += [('/p', _point('nowhere')), ('/p', _point('')),
            ('/p', _point('map#p010')),  # a track id riding in the frame: taken whole, so not placed
            (SONAR_ESTIMATE, _odom('map', '/radar/t0+/patrol/t0')),  # a track id with a leading '/'
            (SLAM_POSE, _odom('map', 'ghost_laser')),
            ('/markers', MarkerArray(markers=[Marker(header=_point('/map').header)])),
            (TF_STATIC, tf_message([planar_transform(0.0, 'odom', 'gps', 0.0, 0.0, 0.0)]))]
    _write(tmp_path / 'bad', bad)
    lines = check_frames(tmp_path / 'bad')
    text = '\n'.join(lines)
    for words in ("frame 'laser' (used on /markers, /slam/pose) cannot be placed",
                  "frame 'base_link'", "frame 'nowhere' (used on /p)", "frame 'ghost_laser'",
                  "frame 'map#p010' (used on /p) cannot be placed in 'map'",
                  '/p: header.frame_id: empty frame id',
                  "/sonar/estimate: child_frame_id (track id): frame id '/radar/t0+/patrol/t0' starts with",
                  "/markers: markers[].header.frame_id: frame id '/map' starts with",
                  "frame 'gps' has several parents: map, odom"):
        assert words in text, text
    assert not any('sonar_track' in line or "'map'" in line.split('(')[0] for line in lines)
    assert main([str(tmp_path / 'bad')]) == 1
    assert len(capsys.readouterr().out.splitlines()) == len(lines)


def test_stamps_outside_the_dynamic_range_are_reported_only_when_asked(tmp_path, capsys):
    def at(msg, t: float):
        header = msg.header if hasattr(msg, 'header') else msg.transforms[0].header
        header.stamp.sec, header.stamp.nanosec = int(t), round((t % 1) * 1e9)
        return msg

    msgs = [(TF_STATIC, tf_message([planar_transform(0.0, 'laser', 'base_link', -3.78, -0.5, 0.0)])),
            (TF, tf_message([planar_transform(1.0, 'map', 'laser', 0.0, 0.0, 0.0)])),
            (TF, tf_message([planar_transform(3.0, 'map', 'laser', 1.0, 0.0, 0.0)])),
            ('/p', at(_point('base_link'), 2.0)), ('/p', at(_point('base_link'), 3.5)),  # after the last /tf
            ('/p', at(_point('map'), 9.0)),  # map needs no transform at any time
            (SLAM_POSE, at(_odom('map', 'laser'), 1.0))]
    _write(tmp_path / 'late', msgs)
    assert check_frames(tmp_path / 'late') == []  # connected
    assert check_frames(tmp_path / 'late', stamps=True) == [
        "/p: 1 of 2 messages in 'base_link' are stamped outside the /tf range of map -> laser [1.000, 3.000] s"]
    assert main([str(tmp_path / 'late'), '--stamps']) == 1
    assert 'outside the /tf range' in capsys.readouterr().out

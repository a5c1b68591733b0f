"""``track_msgs``, the interface package built at install: what ros2cli reads, and the wire format
decoded by an independent reader (rosbags, from the installed .msg text) both ways."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from ament_index_python import get_package_share_directory, get_resource
from rclpy.serialization import deserialize_message, serialize_message
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from std_msgs.msg import Header

import track_msgs.msg
from track_msgs.msg import FusedTrack, FusedTrackArray, PairScore, PairScoreArray, Track, TrackArray

MESSAGES = ('Track', 'TrackArray', 'PairScore', 'PairScoreArray', 'FusedTrack', 'FusedTrackArray')
SHARE = Path(get_package_share_directory('track_msgs')) / 'msg'
INSTALLED = sorted(p.stem for p in SHARE.glob('*.msg'))   # every message ros2 interface show prints


def test_the_ament_index_lists_every_message_with_its_definition():
    """``ros2 interface list/show`` read the rosidl_interfaces resource and the installed .msg files."""
    listed, _ = get_resource('rosidl_interfaces', 'track_msgs')
    share = Path(get_package_share_directory('track_msgs'))
    for name in MESSAGES:
        assert f'msg/{name}.msg' in listed.splitlines()
        assert (share / 'msg' / f'{name}.msg').read_text().strip()


@pytest.mark.parametrize('name', INSTALLED)
def test_every_field_and_constant_is_commented_in_the_installed_definition(name):
    """What ``ros2 interface show`` prints explains each field: every line of the definition has a comment."""
    listed, _ = get_resource('rosidl_interfaces', 'track_msgs')
    assert f'msg/{name}.msg' in listed.splitlines()
    lines = [ln for ln in (SHARE / f'{name}.msg').read_text().splitlines() if ln.strip() and not ln.startswith('#')]
    fields = set(getattr(track_msgs.msg, name).get_fields_and_field_types())
    assert {ln.split()[1].split('=')[0] for ln in lines} >= fields
    uncommented = [ln for ln in lines if '#' not in ln or not ln.split('#', 1)[1].strip()]
    assert not uncommented, uncommented


def test_every_message_is_installed():
    assert set(INSTALLED) >= {*MESSAGES, 'RfidCommand', 'RfidStep', 'IdsqHandoff', 'IdsqAck', 'IdsqRevoke',
                                         'IdsqLeaderEvent'}


def _track_array() -> TrackArray:
    msg = TrackArray(header=Header(frame_id='map'))
    msg.header.stamp.sec, msg.header.stamp.nanosec = 1_767_225_600, 5
    for k in range(3):
        cov = np.diag([4.0 + k, 1e6, 9.0, 1e6]).ravel()
        msg.tracks.append(Track(id=f't{k}', source='radar', x=10.0 * k, vx=0.0, y=-3.5, vy=0.0, covariance=cov))
    return msg


def _typestore():
    """A rosbags type store that knows track_msgs only from the installed .msg files."""
    store = get_typestore(Stores.ROS2_JAZZY)
    share = Path(get_package_share_directory('track_msgs')) / 'msg'
    types = {}
    for name in MESSAGES:
        types |= get_types_from_msg((share / f'{name}.msg').read_text(), f'track_msgs/msg/{name}')
    store.register(types)
    return store


def test_a_track_array_round_trips_through_rclpy():
    msg = _track_array()
    back = deserialize_message(serialize_message(msg), TrackArray)
    assert back == msg and list(back.tracks[2].covariance) == list(msg.tracks[2].covariance)


def test_rosbags_decodes_what_rclpy_encodes_and_the_other_way():
    store = _typestore()
    raw = serialize_message(_track_array())
    decoded = store.deserialize_cdr(raw, 'track_msgs/msg/TrackArray')
    assert [t.id for t in decoded.tracks] == ['t0', 't1', 't2'] and decoded.header.frame_id == 'map'
    assert decoded.tracks[1].x == 10.0 and decoded.tracks[1].covariance[0] == 5.0
    again = deserialize_message(bytes(store.serialize_cdr(decoded, 'track_msgs/msg/TrackArray')), TrackArray)
    assert again == _track_array()


@pytest.mark.parametrize('typename', ['PairScoreArray', 'FusedTrackArray'])
def test_the_fusion_arrays_decode_with_rosbags(typename):
    store = _typestore()
    if typename == 'PairScoreArray':
        msg = PairScoreArray(method='exact', combine='geometric', window=10, threshold=0.5,
                             pairs=[PairScore(a='r/1', b='p/7', score=0.8, combined=0.75, instants=4, associated=True)])
    else:
        msg = FusedTrackArray(tracks=[FusedTrack(a='r/1', b='p/7', x=1.0, y=2.0, covariance=[4.0, 0.5, 0.5, 9.0])])
    decoded = store.deserialize_cdr(serialize_message(msg), f'track_msgs/msg/{typename}')
    item = (decoded.pairs if typename == 'PairScoreArray' else decoded.tracks)[0]
    assert (item.a, item.b) == ('r/1', 'p/7')
    assert deserialize_message(bytes(store.serialize_cdr(decoded, f'track_msgs/msg/{typename}')),
                               type(msg)) == msg


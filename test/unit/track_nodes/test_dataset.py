"""``track-dataset victoria-park``: bag contents, stamps and order on a tiny synthetic data folder; one-line
errors; and the SLAM message conversions it shares with the ``slam`` and ``slam_sim`` nodes."""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
import pytest
from rclpy.serialization import deserialize_message
from rosbags.rosbag2 import Reader

from track_msgs_py.clouds import pointcloud2_to_table
from track_msgs_py.markers.ellipses import ellipse_points
from track_msgs_py.markers.slam import map_markers
from track_msgs_py.odometry import inputs_to_twist, odometry_to_pose, pose_to_odometry, twist_to_inputs
from track_msgs_py.stamps import stamp_to_ns
from track_msgs_py.topics import FRAME_GPS, FRAME_MAP, SLAM_GPS, SLAM_INPUTS, SLAM_SCAN, TF_STATIC, TOPICS
from track_nodes.bag import dataset
from track_nodes.bag.api import msg_class, qos_is_transient_local

INPUTS = [(0.973, 0.0, -0.0035), (0.998, 1.5, -0.0042), (1.023, 2.0, 0.01), (1.048, 2.1, 0.02), (2.5, 2.2, 0.03)]
MEAS = [(0.852, 20.46202, 0.88575, 0.35404), (0.852, 29.59859, 1.02102, 0.25717),
        (1.023, 10.5, 3.14159265, 0.2), (2.0, 5.25, 0.0, 0.1)]
GPS = [(0.0, -2.023, -1.923), (1.001, -2.066, -1.84), (3.0, 1.0, 2.0)]
EPOCH = 1_796_472_000  # --epoch: the bag time of data time 0 [s since 1970]
EPOCH_NS = EPOCH * 10**9


def _data_time(m) -> float:
    """A message's data time: its stamp minus the bag's epoch, in integer ns first."""
    return (stamp_to_ns(m.header.stamp) - EPOCH_NS) / 10**9


def _write(folder: Path, name: str, rows) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / name).write_text(''.join(' '.join(f'{v:.8f}' for v in row) + '\n' for row in rows))


@pytest.fixture
def data(tmp_path) -> Path:
    d = tmp_path / 'vp'
    _write(d, 'inputs.dat', INPUTS)
    _write(d, 'measurements.dat', MEAS)
    _write(d, 'gps.dat', GPS)
    return d


def _read(bag: Path) -> list[tuple[str, int, object]]:
    out = []
    with Reader(bag) as reader:
        types = {c.topic: c.msgtype for c in reader.connections}
        for conn, t, raw in reader.messages():
            out.append((conn.topic, t, deserialize_message(raw, msg_class(types[conn.topic]))))
    return out


def test_bag_holds_inputs_scans_and_gps_stamped_with_the_data_times(data, tmp_path, capsys):
    out = tmp_path / 'bags' / 'vp'  # the parent folder is created
    assert dataset.main(['victoria-park', '--data', str(data), '--out', str(out), '--epoch', str(EPOCH)]) == 0
    assert f'{out}: 12 messages' in capsys.readouterr().out
    assert (out / 'metadata.yaml').is_file() and list(out.glob('*.mcap'))
    msgs = _read(out)
    with Reader(out) as reader:
        assert {c.topic: c.msgtype for c in reader.connections} == {
            t: TOPICS[t].msgtype for t in (SLAM_INPUTS, SLAM_SCAN, SLAM_GPS, TF_STATIC)}
        static = next(c for c in reader.connections if c.topic == TF_STATIC)
        assert qos_is_transient_local(static.ext.offered_qos_profiles)  # the player latches it
    # first the map -> gps transform: the first fix at the map origin
    topic, t_tf, tf = msgs[0]
    assert topic == TF_STATIC and t_tf == EPOCH_NS and len(tf.transforms) == 1
    assert dataset.data_time_origin(out) == EPOCH_NS           # the data time is kept in the metadata
    tr = tf.transforms[0]
    assert (tr.header.frame_id, tr.child_frame_id) == (FRAME_MAP, FRAME_GPS)
    assert (tr.transform.translation.x, tr.transform.translation.y, tr.transform.rotation.w) == (2.023, 1.923, 1.0)
    msgs = msgs[1:]
    # every log time is its header stamp, and the bag is in time order with the scan before the input at 1.023
    assert all(t == stamp_to_ns(m.header.stamp) for _, t, m in msgs)
    assert [t for _, t, _ in msgs] == sorted(t for _, t, _ in msgs)
    order = [(round((t - EPOCH_NS) * 1e-6), topic) for topic, t, _ in msgs]
    assert order.index((1023, SLAM_SCAN)) + 1 == order.index((1023, SLAM_INPUTS))

    inputs = [(_data_time(m), *twist_to_inputs(m)[1:]) for topic, _, m in msgs if topic == SLAM_INPUTS]
    np.testing.assert_array_equal(np.array(inputs), np.array(INPUTS))  # exact: float64 fields, ns stamps
    scans = [(_data_time(m), pointcloud2_to_table(m)) for topic, _, m in msgs if topic == SLAM_SCAN]
    assert [t for t, _ in scans] == [0.852, 1.023, 2.0]
    first = scans[0][1]
    assert list(first) == ['x', 'y', 'z', 'range', 'bearing', 'diameter']  # x, y, z first (issue 19)
    np.testing.assert_allclose(first['x'], first['range'] * np.sin(first['bearing']), rtol=1e-6)
    # raw ranges (to the trunk surface; the slam node adds the radius), float32 precision
    np.testing.assert_allclose(first['range'], [20.46202, 29.59859], rtol=1e-7)
    np.testing.assert_allclose(first['bearing'], [0.88575, 1.02102], rtol=1e-7)
    np.testing.assert_allclose(first['diameter'], [0.35404, 0.25717], rtol=1e-6)
    gps = [(_data_time(m), m.point.x, m.point.y, m.header.frame_id)
           for topic, _, m in msgs if topic == SLAM_GPS]
    assert gps == [(*row, 'gps') for row in GPS]


def test_bag_decodes_with_the_mcap_reader_too(data, tmp_path):
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    out = tmp_path / 'bag'
    assert dataset.main(['victoria-park', '--data', str(data), '--out', str(out), '--epoch', str(EPOCH)]) == 0
    with open(next(out.glob('*.mcap')), 'rb') as f:
        decoded = [(ch.topic, m) for _, ch, _, m in make_reader(f, decoder_factories=[DecoderFactory()])
                   .iter_decoded_messages()]
    twist = next(m for topic, m in decoded if topic == SLAM_INPUTS and m.header.stamp.sec == EPOCH
                 and m.header.stamp.nanosec == 998_000_000)
    assert (twist.twist.linear.x, twist.twist.angular.z) == (1.5, -0.0042)
    assert len(decoded) == 12


def test_t_max_keeps_a_short_stretch(data, tmp_path):
    out = tmp_path / 'short'
    assert dataset.main(['victoria-park', '--data', str(data), '--out', str(out), '--t-max', '1.01']) == 0
    msgs = _read(out)
    origin = dataset.data_time_origin(out)    # default epoch: the stretch ends at the conversion's second
    assert max(t for _, t, _ in msgs) <= origin + 1_010_000_000 and origin % 10**9 == 0
    assert abs(origin + 2 * 10**9 - time.time_ns()) < 120 * 10**9   # ceil(1.01 s) before a whole second
    assert [topic for topic, _, _ in msgs].count(SLAM_INPUTS) == 2
    assert [topic for topic, _, _ in msgs].count(SLAM_SCAN) == 1


@pytest.mark.parametrize(('setup', 'args', 'words'), [
    ('none', ['--data', '{tmp}/nope'], ['nope', 'not found']),
    ('no_gps', ['--data', '{tmp}/vp'], ['missing gps.dat']),
    ('garbled', ['--data', '{tmp}/vp'], ['cannot read']),
    ('exists', ['--data', '{tmp}/vp'], ['exists already']),
    ('none', ['--data', '{tmp}/vp', '--t-max', '-1'], ['--t-max', 'must be > 0']),
    ('none', ['--data', '{tmp}/vp', '--epoch', 'yesterday'], ['--epoch', 'yesterday']),
])
def test_errors_are_one_line_with_exit_code_2(data, tmp_path, capsys, setup, args, words):
    out = tmp_path / 'out'
    if setup == 'no_gps':
        (data / 'gps.dat').unlink()
    elif setup == 'garbled':
        (data / 'inputs.dat').write_text('0.1 0.2 zero\n')
    elif setup == 'exists':
        out.mkdir()
    code = dataset.main(['victoria-park', '--out', str(out), *[a.format(tmp=tmp_path) for a in args]])
    err = capsys.readouterr().err
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith('track-dataset: '), err
    assert all(w in lines[0] for w in words), lines[0]
    assert setup == 'exists' or not out.exists()


def test_missing_arguments_are_one_line(capsys):
    with pytest.raises(SystemExit) as exc:
        dataset.main(['victoria-park'])
    assert exc.value.code == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1


# --- conversions of the SLAM topics ---------------------------------------------------------------

def test_pose_odometry_round_trip():
    P = np.array([[0.5, 0.1, 0.01], [0.1, 0.4, -0.02], [0.01, -0.02, 0.003]])
    for yaw in (0.3, -2.9, math.pi - 1e-9):
        msg = pose_to_odometry(12.375, np.array([3.0, -4.0, yaw]), P)
        t, pose, cov = odometry_to_pose(msg)
        assert t == 12.375 and msg.header.frame_id == 'map' and msg.child_frame_id == 'laser'
        np.testing.assert_allclose(pose, [3.0, -4.0, yaw], atol=1e-12)
        np.testing.assert_array_equal(cov, P)
        full = np.asarray(msg.pose.covariance).reshape(6, 6)
        assert full[2, 2] == full[3, 3] == full[4, 4] == 0.0  # z, roll, pitch: planar (issue 19)


def test_inputs_twist_round_trip():
    assert twist_to_inputs(inputs_to_twist(0.973, 2.5, -0.31)) == (0.973, 2.5, -0.31)


def test_batched_ellipses_equal_checked_ellipse_points():
    from track_core.filters import ellipse_points as ellipses

    rng = np.random.default_rng(3)
    A = rng.normal(size=(5, 2, 2))
    covs = A @ np.swapaxes(A, -1, -2) + 0.01 * np.eye(2)
    covs[4] = [[1.0, 1.0], [1.0, 1.0]]  # singular (PSD): a segment
    lm = rng.normal(size=(5, 2)) * 10
    pts = ellipses(lm, covs, 2.0, 20)
    for i in range(5):
        np.testing.assert_allclose(pts[i], ellipse_points(lm[i], covs[i], 2.0, 20), atol=1e-12)
    msg = map_markers(1.0, lm, covs, n_points=20)
    assert [m.ns for m in msg.markers] == ['', 'slam_landmarks'] + ['slam_ellipses'] * 5
    assert len(msg.markers[1].points) == 5 and len(msg.markers[2].points) == 21

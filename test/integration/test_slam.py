"""Hybrid SLAM nodes (issue 7): ``slam`` on the converted Victoria Park bag, bad input, the ``slam_sim``
and ``victoria_park`` scenarios through the launcher, and the converter's one-line error.

- A short stretch of the real run (``track-dataset victoria-park --t-max``), replayed with the player
  into ``slam``: it publishes a pose per scan and the map, the path stays near the GPS after the
  rigid alignment, and it equals the core's offline run (``victoria.events`` into ``HybridSlam``) on
  the same (float32) observations: the node adds no maths and processes in the offline order.
- Bad input: negative range, NaN and out-of-range bearings are dropped with one throttled warning,
  backwards stamps are refused without touching the filter, and the node keeps running.

Skipped, with the reason, when the Victoria Park data folder is missing.
"""

from __future__ import annotations

import copy
import importlib.util
import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from geometry_msgs.msg import PointStamped, TwistStamped
from nav_msgs.msg import Odometry
from rcl_interfaces.msg import Log
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from rosbags.rosbag2 import Reader
from sensor_msgs.msg import PointCloud2
from visualization_msgs.msg import MarkerArray

from track_core.slam import HybridParams, HybridSlam, victoria
from track_core.slam.profiles import VICTORIA_PARK, loop_sim_params
from track_core.slam.sim import LoopWorld, simulate
from track_msgs import msg as tm
from track_msgs_py.clouds import scan_to_pointcloud2, table_to_pointcloud2
from track_msgs_py.odometry import inputs_to_twist, odometry_to_pose, pose_array_to_positions
from track_msgs_py.qos import ESTIMATE_QOS, STATIC_QOS
from track_msgs_py.records.slam import SlamMode
from track_msgs_py.stamps import stamp_to_ns, stamp_to_sec
from track_msgs_py.topics import SLAM_EVENTS, SLAM_GPS, SLAM_INPUTS, SLAM_MAP, SLAM_MODE, SLAM_POSE, SLAM_SCAN
from track_nodes.bag.api import msg_class
from track_nodes.bag.check import check_bag
from track_nodes.bag.dataset import convert_victoria_park, data_time_origin
from track_nodes.bag.frames import check_frames
from track_nodes.bag.player import PlayerNode
from track_nodes.base import ParameterError
from track_nodes.slam.slam import SlamNode
from track_nodes.slam.slam_sim import SlamSimNode

DISPLAYS = Path(__file__).resolve().parents[2] / 'tools/displays.py'  # a script, not a package module: loaded by path
_spec = importlib.util.spec_from_file_location('displays_tool', DISPLAYS)
_displays = sys.modules.setdefault('displays_tool', importlib.util.module_from_spec(_spec))  # dataclasses look it up
_spec.loader.exec_module(_displays)
undrawn_in_bag = _displays.undrawn_in_bag

T_MAX = 40.0  # the stretch of the real run [s]
DEEP = QoSProfile(depth=100_000, reliability=ReliabilityPolicy.RELIABLE)


def _data_or_skip() -> Path:
    path = victoria.data_dir()
    if not (path / 'measurements.dat').is_file():
        pytest.skip(f'Victoria Park data not found at {path} (set TRACK_VICTORIA_PARK or TRACK_DATA_DIR)')
    return path


def _convert(out: Path, t_max: float, env: dict) -> None:
    # the module behind the track-dataset console script (also works from a source tree on PYTHONPATH)
    proc = subprocess.run([sys.executable, '-m', 'track_nodes.bag.dataset', 'victoria-park', '--out', str(out),
                           '--t-max', str(t_max)], capture_output=True, text=True, timeout=120, env=env)
    assert proc.returncode == 0, proc.stderr
    assert f'{out}:' in proc.stdout


@pytest.fixture(scope='module')
def vp_bag(tmp_path_factory, env_factory) -> Path:
    """The first T_MAX seconds of Victoria Park, converted by the console command."""
    _data_or_skip()
    out = tmp_path_factory.mktemp('vp') / 'victoria_park'
    _convert(out, T_MAX, env_factory())
    return out


class Sink:
    def __init__(self, ros) -> None:
        self.node = ros.add(Node('slam_sink', context=ros.context))
        self.msgs: dict[str, list] = {}
        for topic, cls, qos in ((SLAM_POSE, Odometry, DEEP), (SLAM_MODE, tm.SlamStatus, DEEP),
                                (SLAM_EVENTS, tm.SlamEvent, DEEP), (SLAM_GPS, PointStamped, DEEP),
                                (SLAM_MAP, MarkerArray, STATIC_QOS), ('/rosout', Log, DEEP)):
            self.msgs[topic] = []
            self.node.create_subscription(cls, topic, self.msgs[topic].append, qos)

    def logs(self, node: str, text: str) -> list[str]:
        return [m.msg for m in self.msgs['/rosout'] if m.name == node and text in m.msg]


def _offline_reference(t_max: float):
    """The core alone, fed like ``experiments.run_victoria``, on the observations as the bag carries them
    (float32 fields, the node's range + diameter/2 and bearing clip): poses after each scan, final map."""
    vp = victoria.load(t_max=t_max, add_radius=False)
    scans = []
    for z, d in zip(vp.scans, vp.diameters, strict=True):
        r, b, dd = (np.asarray(c, dtype=np.float32).astype(float) for c in (z[:, 0], z[:, 1], d))
        scans.append(np.stack([r + 0.5 * dd, np.clip(b, 0.0, np.pi)], axis=1))
    vp.scans = scans
    h = HybridSlam(np.zeros(3), np.diag([1e-6] * 3), np.random.default_rng(0), VICTORIA_PARK.slam, VICTORIA_PARK.pf,
                   HybridParams())
    t, poses = [], []
    for ev in victoria.events(vp):
        if ev[0] == 'input':
            h.process_input(*ev[1:])
        else:
            h.process_scan(ev[1], ev[2])
            t.append(ev[1])
            poses.append(h.pose.copy())
    return np.array(t), np.array(poses), h, vp


def test_slam_node_on_a_victoria_park_stretch(ros, vp_bag):
    # wall time; the laser's pose (the filter state), as the offline reference
    slam = ros.add(SlamNode(context=ros.context, parameter_overrides=[Parameter('pose_of', value='laser')]))
    sink = Sink(ros)
    n_scans = len(victoria.load(t_max=T_MAX).scans)
    player = ros.add(PlayerNode(context=ros.context, parameter_overrides=[
        Parameter('bag', value=str(vp_bag)), Parameter('rate', value=20.0)]))
    assert ros.spin_until(lambda: player.done.is_set() and slam.n_scans == n_scans and not len(slam.merger)
                          and len(sink.msgs[SLAM_POSE]) == len(sink.msgs[SLAM_MODE]) == n_scans, timeout=90), \
        f'processed {slam.n_scans}/{n_scans} scans, {len(sink.msgs[SLAM_POSE])} poses received'
    assert player.exit_code == 0
    assert ros.spin_until(lambda: sink.msgs[SLAM_MAP] and stamp_to_ns(sink.msgs[SLAM_MAP][-1].markers[0].header.stamp)
                          == slam.processed_ns, timeout=10)  # the final map, published once the input went idle
    assert slam.n_refused == 0 and slam.n_dropped_obs == 0
    # a pose per scan, in order, and the map
    est = [odometry_to_pose(m) for m in sink.msgs[SLAM_POSE]]
    origin = data_time_origin(vp_bag)                     # the bag is dated: data time = stamp - origin
    assert origin >= 1_700_000_000 * 10**9 and origin % 10**9 == 0
    t_est = np.array([(stamp_to_ns(m.header.stamp) - origin) / 10**9 for m in sink.msgs[SLAM_POSE]])
    x_est = np.array([e[1] for e in est])
    assert np.all(np.diff(t_est) > 0)
    assert all(np.all(np.linalg.eigvalsh(P) > 0) for _, _, P in est)
    mode = SlamMode.from_msg(sink.msgs[SLAM_MODE][-1])
    assert mode.scans == n_scans and mode.landmarks >= 20
    last_map = sink.msgs[SLAM_MAP][-1].markers
    means = next(m for m in last_map if m.ns == 'slam_landmarks')
    assert len(means.points) == mode.landmarks
    assert sum(m.ns == 'slam_ellipses' for m in last_map) == len(means.points)
    # near the GPS after the rigid alignment (the core reaches ~0.8 m on the first 60 s)
    gps = np.array([[(stamp_to_ns(m.header.stamp) - origin) / 10**9, m.point.x, m.point.y]
                    for m in sink.msgs[SLAM_GPS]])
    rmse, _, used = victoria.gps_rmse(t_est, x_est[:, :2], gps)
    print(f'GPS RMSE {rmse:.3f} m over {len(used)} fixes, {mode.landmarks} landmarks')
    assert len(used) > 100 and rmse < 2.0
    # the same as the core run offline on the same observations, in the same order
    t_ref, x_ref, h, _ = _offline_reference(T_MAX)
    np.testing.assert_array_equal(t_est, t_ref)
    np.testing.assert_allclose(x_est, x_ref, atol=1e-6)
    ref_lm = h.landmarks()
    got_lm = np.array([(p.x, p.y) for p in means.points])
    assert got_lm.shape == ref_lm.shape
    np.testing.assert_allclose(got_lm, ref_lm, atol=1e-6)


# --- bad input ---------------------------------------------------------------------------------------------

def _state(slam: SlamNode):
    s = slam.slam
    x, P = copy.deepcopy(s.cekf).mean_cov()
    return s.t, s.u.copy(), s.mode, x, P


def _bad_input_rig(ros):
    """A slam node, a sink and publishers of inputs and scans in the test's context, matched."""
    slam = ros.add(SlamNode(context=ros.context, parameter_overrides=[Parameter('warn_throttle', value=60.0)]))
    sink = Sink(ros)
    pub = ros.add(Node('slam_test_source', context=ros.context))
    inputs = pub.create_publisher(TwistStamped, SLAM_INPUTS, ESTIMATE_QOS)
    scans = pub.create_publisher(PointCloud2, SLAM_SCAN, ESTIMATE_QOS)
    assert ros.spin_until(lambda: inputs.get_subscription_count() > 0 and scans.get_subscription_count() > 0
                          and slam.pub_pose.get_subscription_count() > 0)
    return slam, sink, inputs, scans


def test_bad_observations_are_dropped_and_backwards_stamps_refused(ros):
    slam, sink, inputs, scans = _bad_input_rig(ros)
    trees = np.array([[10.0, 1.0], [12.0, 2.0], [15.0, 1.5]])

    def scan(t, z, d=None):
        scans.publish(scan_to_pointcloud2(t, z, np.full(len(z), 0.3) if d is None else d))

    inputs.publish(inputs_to_twist(1.0, 1.0, 0.0))
    scan(1.05, trees)
    inputs.publish(inputs_to_twist(1.1, 1.0, 0.0))
    assert ros.spin_until(lambda: slam.n_scans == 1 and len(sink.msgs[SLAM_POSE]) == 1)
    # negative range, NaN range, NaN bearing, bearing beyond π, negative bearing: dropped; the good rows stay
    bad = np.array([[-3.0, 1.0], [np.nan, 1.2], [11.0, np.nan], [11.0, 4.0], [11.0, -0.5]])
    scan(1.2, np.vstack([trees, bad]))
    inputs.publish(inputs_to_twist(1.3, 1.0, 0.0))
    assert ros.spin_until(lambda: slam.n_scans == 2 and len(sink.msgs[SLAM_POSE]) == 2)
    assert slam.n_dropped_obs == 5
    scan(1.35, np.vstack([trees, bad[:2]]))  # a second bad scan soon after: counted, not logged again
    inputs.publish(inputs_to_twist(1.4, 1.0, 0.0))
    assert ros.spin_until(lambda: slam.n_scans == 3)
    assert slam.n_dropped_obs == 7
    inputs.publish(inputs_to_twist(1.45, math.nan, 0.0))  # a non-finite input: dropped
    scans.publish(table_to_pointcloud2(1.45, 'laser', {'r': np.ones(2)}))  # no range/bearing fields: dropped
    assert ros.spin_until(lambda: slam.n_bad_inputs == 1 and slam.n_bad_scans == 1)
    ros.spin_for(0.8)  # past flush_idle: the held input of 1.4 s is processed
    assert slam.processed_ns == 1_400_000_000

    before = _state(slam)
    pose_msgs = len(sink.msgs[SLAM_POSE])
    inputs.publish(inputs_to_twist(0.5, 9.0, 0.4))  # backwards on the input topic (last 1.4)
    scan(1.1, trees)                                # backwards on the scan topic (last 1.35)
    assert ros.spin_until(lambda: slam.n_refused == 2)
    ros.spin_for(0.8)  # past flush_idle: anything buffered would now be processed
    after = _state(slam)
    assert (before[0], before[2]) == (after[0], after[2]) and slam.processed_ns == 1_400_000_000
    np.testing.assert_array_equal(before[1], after[1])
    np.testing.assert_array_equal(before[3], after[3])
    np.testing.assert_array_equal(before[4], after[4])
    assert len(sink.msgs[SLAM_POSE]) == pose_msgs
    # ... and the node keeps running
    scan(1.6, trees)
    inputs.publish(inputs_to_twist(1.7, 1.0, 0.0))
    assert ros.spin_until(lambda: slam.n_scans == 4 and len(sink.msgs[SLAM_POSE]) == pose_msgs + 1
                          and len(sink.msgs[SLAM_MODE]) == 4)
    assert odometry_to_pose(sink.msgs[SLAM_POSE][-1])[0] == 1.6
    mode = SlamMode.from_msg(sink.msgs[SLAM_MODE][-1])
    assert (mode.dropped_observations, mode.refused_messages, mode.bad_inputs, mode.bad_scans) == (7, 2, 1, 1)
    # one warning per kind: throttled
    assert ros.spin_until(lambda: len(sink.logs('slam', 'refused')) >= 1, timeout=5)
    assert len(sink.logs('slam', 'observations dropped')) == 1, sink.logs('slam', '')
    assert len(sink.logs('slam', 'time went backwards')) == 2  # one per topic (refuse: per topic and reason)
    assert len(sink.logs('slam', f'{SLAM_INPUTS}: refused: twist.linear')) == 1
    assert len(sink.logs('slam', f'{SLAM_SCAN}: refused: scan')) == 1
    assert 'range -3' in sink.logs('slam', 'observations dropped')[0]


# --- scenarios through the launcher ---------------------------------------------------------------------------

def _bag_counts(bag: Path) -> dict[str, int]:
    with Reader(bag) as reader:
        return {c.topic: c.msgcount for c in reader.connections}


def test_slam_sim_scenario_short_run(tmp_path, repo, env_factory):
    cmd = [sys.executable, '-m', 'track_nodes.launch', str(repo / 'config/slam_sim.yaml'), '--record', 'sim',
           '--duration', '6', '--rate', '50']
    proc = subprocess.run(cmd, cwd=tmp_path, env=env_factory(), capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-3000:]
    counts = _bag_counts(tmp_path / 'bags/sim')
    assert counts['/slam/truth'] >= 55 and counts['/slam/inputs'] >= 55  # t = 0 .. 6 s every 0.1 s
    assert counts[SLAM_POSE] >= 25 and counts[SLAM_MODE] == counts[SLAM_POSE] and counts[SLAM_MAP] >= 2
    m = re.search(r'final position error ([\d.]+) m', proc.stdout)
    assert m, proc.stdout
    assert float(m.group(1)) < 1.0  # 6 s into the start area: well mapped, no loop closed yet
    assert 'PF switches 0' in proc.stdout
    res = check_bag(tmp_path / 'bags/sim')  # issue 19: clouds with x, y, z and planar covariances
    assert res.ok and res.checked[SLAM_POSE] == counts[SLAM_POSE] and res.checked[SLAM_SCAN] > 0, res.problems
    assert check_frames(tmp_path / 'bags/sim') == []  # laser, base_link (slam) and laser_truth (slam_sim)
    assert undrawn_in_bag('slam', tmp_path / 'bags/sim') == []  # every 3D entry of slam.json recorded, drawable
    # one per truth and per pose, none lost, and the first input's (it comes before the first scan)
    assert counts['/tf'] == counts['/slam/truth'] + counts[SLAM_POSE] + 1
    # not stamps=True: the run may stop with inputs after the last scan the filter has released


def test_victoria_park_scenario_replays_the_bag_into_slam(tmp_path, repo, env_factory):
    _data_or_skip()
    env = env_factory()
    _convert(tmp_path / 'bags/victoria_park', 10.0, env)  # the scenario's bag name, relative to the cwd
    fast = tmp_path / 'fast.yaml'
    fast.write_text('player:\n  ros__parameters:\n    rate: 20.0\n')
    # the scenario runs on wall time (its /clock is the bag's): it ends once the bag (10 s at 20x) has been
    # played and slam is done, however slow the machine; --duration is only the bound
    cmd = [sys.executable, '-m', 'track_nodes.launch', str(repo / 'config/victoria_park.yaml'), '--record', 'vp',
           '--duration', '240', '--params', str(fast)]
    proc = subprocess.run(cmd, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=400)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert 'the bag has been played' in proc.stdout, proc.stdout
    counts = _bag_counts(tmp_path / 'bags/vp')
    n_scans = len(victoria.load(t_max=10.0).scans)
    assert counts[SLAM_POSE] == n_scans and counts[SLAM_GPS] > 20 and counts[SLAM_MAP] >= 1
    assert SLAM_INPUTS not in counts  # the replayed inputs and scans are not recorded again
    m = re.search(r'vs GPS: RMSE ([\d.]+) m', proc.stdout)
    assert m and float(m.group(1)) < 2.0, proc.stdout
    res = check_bag(tmp_path / 'bags/vp')
    assert res.ok and res.checked[SLAM_POSE] == n_scans, res.problems
    assert check_frames(tmp_path / 'bags/vp') == []  # laser and base_link placed by slam; gps by the converted bag


def test_converter_wrong_path_is_one_line(tmp_path, env_factory):
    out = tmp_path / 'out'
    proc = subprocess.run([sys.executable, '-m', 'track_nodes.bag.dataset', 'victoria-park', '--data',
                           str(tmp_path / 'nope'), '--out', str(out)],
                          capture_output=True, text=True, timeout=60, env=env_factory())
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and 'Traceback' not in proc.stderr, proc.stderr
    assert str(tmp_path / 'nope') in lines[0] and 'not found' in lines[0]
    assert not out.exists()


def test_converted_bag_is_dated_at_its_epoch_to_the_nanosecond(tmp_path):
    """Data time t is bag time epoch + t in integer ns: header stamps, log times, metadata.yaml and the MCAP
    summary agree exactly (a float epoch + t is off by up to ~1e-7 s), and the data time is in the metadata."""
    import yaml
    from mcap.reader import make_reader

    _data_or_skip()
    epoch = 1_796_472_000  # 2026-12-05T12:00:00Z
    out = tmp_path / 'vp'
    convert_victoria_park(out, t_max=5.0, epoch=epoch)
    vp = victoria.load(t_max=5.0, add_radius=False)
    assert data_time_origin(out) == epoch * 10**9
    meta = yaml.safe_load((out / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert meta['custom_data']['data_set'] == 'victoria_park' and meta['ros_distro'] == 'jazzy'
    with Reader(out) as reader:
        rows = [(c.topic, t, deserialize_message(raw, msg_class(c.msgtype))) for c, t, raw in reader.messages()]
    stamps = [stamp_to_ns((m.header if hasattr(m, 'header') else m.transforms[0].header).stamp) for _, _, m in rows]
    assert [t for _, t, _ in rows] == stamps                          # log time = header stamp, in ns
    scans = [s for (topic, _, _), s in zip(rows, stamps, strict=True) if topic == SLAM_SCAN]
    assert scans == [epoch * 10**9 + round(float(t) * 1e9) for t in vp.scan_t]
    with (out / 'vp.mcap').open('rb') as f:
        stats = make_reader(f).get_summary().statistics
    assert meta['starting_time']['nanoseconds_since_epoch'] == stats.message_start_time == min(stamps)
    assert meta['duration']['nanoseconds'] == stats.message_end_time - stats.message_start_time


def test_converted_bag_decodes_by_type_name(vp_bag):
    """The converted bag reads with rclpy's deserialiser by type name (what the player relies on)."""
    with Reader(vp_bag) as reader:
        conn = next(c for c in reader.connections if c.topic == SLAM_SCAN)
        _, t, raw = next(iter(reader.messages(connections=[conn])))
    msg = deserialize_message(raw, msg_class(conn.msgtype))
    assert [f.name for f in msg.fields] == ['x', 'y', 'z', 'range', 'bearing', 'diameter'] and msg.width > 0
    res = check_bag(vp_bag)  # issue 19: every scan drawable (float32 x, y, z first)
    assert res.ok and res.checked[SLAM_SCAN] > 10, res.problems
    assert t == msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec


@pytest.mark.parametrize(('cls', 'name', 'value', 'words'), [
    (SlamNode, 'cekf.sigma_r', -1.0, ['cekf.sigma_r', '-1', '> 0']),
    (SlamNode, 'profile', 'nope', ['profile', 'victoria_park']),
    (SlamNode, 'pose0', [1.0, 2.0], ['pose0', '3 finite']),
    (SlamNode, 'hybrid.bearing_limits', [1.0, 0.5], ['hybrid.bearing_limits', 'low < high']),
    (SlamSimNode, 'world.dt', -1.0, ['world.dt', '-1', 'allowed']),
])
def test_bad_parameters_are_one_line(ros, cls, name, value, words):
    with pytest.raises(ParameterError) as exc:
        cls(context=ros.context, parameter_overrides=[Parameter(name, value=value)])
    text = str(exc.value)
    assert '\n' not in text and all(w in text for w in words), text


# --- map estimate and the particle cloud -----------------------------------------------------------------------

def _deepcopy_map(h: HybridSlam):
    """The map as the node used to publish it: ``mean_cov`` (a global update) on a deep copy of the CEKF."""
    x, P = copy.deepcopy(h.cekf).mean_cov()
    idx = 3 + 2 * np.arange((x.size - 3) // 2)
    r2 = idx[:, None, None] + np.arange(2)[None, :, None]
    return x[3:].reshape(-1, 2), P[r2, np.swapaxes(r2, 1, 2)]


def _check_map_estimates(h: HybridSlam, checks: list) -> None:
    m, C = h.map_estimate()
    m_ref, C_ref = _deepcopy_map(h)
    assert m.shape == m_ref.shape and C.shape == C_ref.shape
    np.testing.assert_allclose(m, m_ref, rtol=0, atol=1e-12)
    np.testing.assert_allclose(C, C_ref, rtol=0, atol=1e-12)
    checks.append((len(m), bool(h.cekf.track and h.cekf.b_idx.size)))


def test_map_estimate_equals_the_deepcopy_path_on_victoria_park():
    _data_or_skip()
    vp = victoria.load(t_max=80.0)  # passive landmarks (the compressed phase) from about 60 s
    h = HybridSlam(np.zeros(3), np.diag([1e-6] * 3), np.random.default_rng(0), VICTORIA_PARK.slam, VICTORIA_PARK.pf,
                   HybridParams())
    checks, n = [], 0
    for ev in victoria.events(vp):
        if ev[0] == 'input':
            h.process_input(*ev[1:])
            continue
        h.process_scan(ev[1], ev[2])
        n += 1
        if n % 10 == 0:
            _check_map_estimates(h, checks)
    assert len(checks) >= 10 and checks[-1][0] >= 15
    assert any(compressed for _, compressed in checks)  # also with passive landmarks to correct on the fly


def test_map_estimate_equals_the_deepcopy_path_in_the_loop_world():
    w = LoopWorld()
    sp, pp = loop_sim_params(w)
    run = simulate(w, np.random.default_rng(1))
    h = HybridSlam(w.start(), np.diag([1e-6] * 3), np.random.default_rng(2), sp, pp,
                   HybridParams(trigger_on_ambiguity=True))
    checks, si = [], 0
    for k in range(len(run.t)):
        if run.t[k] > 60.0:  # the start area and the first leg
            break
        h.process_input(run.t[k], *run.u_meas[k])
        while si < len(run.scans) and run.scans[si][0] <= run.t[k] + w.dt + 1e-9:
            h.process_scan(*run.scans[si][:2])
            si += 1
            if si % 25 == 0:
                _check_map_estimates(h, checks)
    assert len(checks) >= 10 and checks[-1][0] >= 20
    assert any(compressed for _, compressed in checks)


def test_slam_node_publishes_the_cloud_of_every_pf_scan(ros):
    """The slam_sim scenario's run (config/slam_sim.yaml seeds) replayed into ``slam``: the PF starts on the
    loop-closing scan and converges a few scans later; the node publishes the cloud of every PF scan (the
    converging one included), then an empty array."""
    w = LoopWorld()
    run = simulate(w, np.random.default_rng(1))
    slam = ros.add(SlamNode(context=ros.context, parameter_overrides=[
        Parameter('profile', value='loop_sim'), Parameter('seed', value=2), Parameter('add_radius', value=False),
        Parameter('pose_of', value='laser'),
        Parameter('map_period', value=1000.0)]))
    clouds = []  # every PoseArray the node publishes (the topic is best effort: spy on the publisher)
    publish = slam.pub_particles.publish
    slam.pub_particles.publish = lambda msg: (clouds.append(msg), publish(msg))
    pub = ros.add(Node('slam_sim_source', context=ros.context))
    inputs = pub.create_publisher(TwistStamped, SLAM_INPUTS, DEEP)
    scans = pub.create_publisher(PointCloud2, SLAM_SCAN, DEEP)
    assert ros.spin_until(lambda: inputs.get_subscription_count() > 0 and scans.get_subscription_count() > 0)
    si = 0
    for k in range(len(run.t)):  # in stamp order, scan first at equal stamps (as slam_sim publishes)
        while si < len(run.scans) and run.scans[si][0] <= run.t[k] + 1e-9:
            scans.publish(scan_to_pointcloud2(run.scans[si][0], run.scans[si][1]))
            si += 1
        inputs.publish(inputs_to_twist(run.t[k], *run.u_meas[k]))
    for ts, z, _ in run.scans[si:]:
        scans.publish(scan_to_pointcloud2(ts, z))
    assert ros.spin_until(lambda: slam.n_scans == len(run.scans) and not len(slam.merger), timeout=60), \
        f'processed {slam.n_scans}/{len(run.scans)} scans'
    h = slam.slam
    assert [e.kind for e in h.events] == ['to_pf', 'to_cekf']
    k = h.events[1].scans
    assert 1 <= k <= 3
    t_pf = h.events[1].t   # the converging scan
    assert len(clouds) == k + 1, [(stamp_to_sec(c.header.stamp), len(c.poses)) for c in clouds]
    assert stamp_to_sec(clouds[0].header.stamp) == pytest.approx(h.events[0].t, abs=1e-9)
    assert all(len(c.poses) > 0 for c in clouds[:k])
    cloud, empty = clouds[k - 1:]
    assert stamp_to_sec(cloud.header.stamp) == pytest.approx(t_pf, abs=1e-9)
    assert stamp_to_sec(empty.header.stamp) == pytest.approx(t_pf + w.scan_every * w.dt, abs=1e-9)  # the next scan
    assert len(empty.poses) == 0 and cloud.header.frame_id == slam.p.frame_id
    xy, heading = pose_array_to_positions(cloud)
    step = h.last_particles
    n = len(step.particles)
    assert len(xy) == math.ceil(n / math.ceil(n / 500))  # the node's even subsample of the PF's last cloud
    sub = step.particles[::math.ceil(n / 500)]
    np.testing.assert_allclose(xy, sub[:, :2], atol=1e-9)
    np.testing.assert_allclose(np.cos(heading - sub[:, 2]), 1.0, atol=1e-9)
    truth = run.truth[round(t_pf / w.dt)]
    err = float(np.linalg.norm(xy.mean(axis=0) - truth[:2]))
    print(f'{k}-scan PF episode converged at t = {t_pf:.1f} s: {len(xy)} poses, mean {err:.2f} m from the truth')
    assert err < 2.0


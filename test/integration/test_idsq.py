"""IDSQ network (issue 6): vehicle_sim and one acoustic_sensor / doa_sensor node per sensor.

- In-process (the test drives /clock, one tick per tracker step): the network tracks the vehicle
  of config/idsq.yaml (K = 24) and equals, bit for bit, the core-only loop of ``leader_step`` with
  the same per-(sensor, step) draws.
- One process per sensor (launcher ``--processes``, K = 8 to keep it short) records the same
  estimates as the in-process network on the same scenario file.
- Leader failure: the sensor that is about to receive the handoff is destroyed mid-track; the
  sender re-selects after the ack timeout and the track continues with bounded error.
- Malformed handoffs (NaN, negative mass, wrong grid, unknown version, arrays of different lengths)
  are refused with a warning and a nack; a sensor refusing every handoff makes its senders re-select.
- The recorded protocol topics (track_msgs IdsqHandoff, IdsqAck, IdsqLeaderEvent) decode with rosbags
  from the schemas the bag embeds.
- Readings: the sensors hear only their readings (no truth subscription); a missing reading makes its
  leader lead the step predict-only after ``reading_timeout`` and hand on, a late one is dropped
  (both counted); recorded readings replayed with the player into a fresh network (no vehicle_sim)
  give its estimates bit for bit; the "bring your own sensor" example of docs/USAGE.md (a DOA front
  end and microphones, no truth anywhere) gets a track.
"""

from __future__ import annotations

import math
import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from nav_msgs.msg import Odometry
from rcl_interfaces.msg import Log
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosgraph_msgs.msg import Clock

from track_core.idsq import (
    GridSpec,
    Handoff,
    encode_handoff,
)
from track_core.idsq.leader_protocol import protocol_track, step_of_stamp
from track_core.idsq.simulation import scenario_of
from track_msgs import msg as tm
from track_msgs_py.covariance import xy_block
from track_msgs_py.odometry import odometry_to_cv_state
from track_msgs_py.qos import CLOCK_QOS, ESTIMATE_QOS, HANDOFF_QOS
from track_msgs_py.records.idsq import IdsqAck, IdsqHandoff, IdsqLeaderEvent, IdsqRevoke
from track_msgs_py.records.idsq import layout_to_pointcloud2 as layout_to_cloud
from track_msgs_py.records.idsq import pointcloud2_to_layout as cloud_to_layout
from track_msgs_py.stamps import sec_to_stamp, stamp_to_sec
from track_msgs_py.topics import (
    CLOCK,
    IDSQ_BELIEF,
    IDSQ_ESTIMATE,
    IDSQ_HANDOFF_REGEX,
    IDSQ_LAYOUT,
    IDSQ_LEADER,
    IDSQ_TRUTH,
    idsq_ack_topic,
    idsq_handoff_topic,
    idsq_reading_topic,
    idsq_revoke_topic,
)
from track_nodes.bag.check import check_bag
from track_nodes.bag.frames import check_frames
from track_nodes.base.scenario_file import node_params
from track_nodes.idsq.scenario_files import idsq_yaml as scenario_yaml
from track_nodes.launch.hosts import remove_leftovers, unavailable
from track_nodes.launch.scenario import load_scenario
from track_nodes.report.idsq import recorded_track

DT = 0.5
EPOCH = 1000  # the in-process network's /clock starts here (the launcher's at --epoch, by default now)
K8_STEPS = 20  # 10 s of the K = 8 scenario


# --- helpers ----------------------------------------------------------------------------------------

def reference_track(seed: int, n_sensors: int, n_steps: int) -> tuple[np.ndarray, np.ndarray, list[int]]:
    """The network's track with the core only: (means (T, 2), covariances (T, 2, 2), leaders)."""
    return protocol_track(seed, n_sensors, n_steps)


class Network:
    """All nodes of a scenario file in the test's context, a /clock publisher and collectors."""

    def __init__(self, ros, cfg: Path, overrides: dict[str, list[Parameter]] | None = None) -> None:
        self.ros, self.cfg = ros, cfg
        self.nodes: dict[str, Node] = {}
        for spec in load_scenario(str(cfg)).nodes:
            params = [Parameter('use_sim_time', value=True), *(overrides or {}).get(spec.name, [])]
            self.nodes[spec.name] = ros.add(spec.node_class()(
                node_name=spec.name, context=ros.context, parameter_overrides=params,
                cli_args=['--ros-args', '--params-file', str(cfg)]))
        self.vehicle = self.nodes['vehicle_sim']
        self.sensors = {n.id: n for n in self.nodes.values() if hasattr(n, 'led')}
        self.probe = ros.add(Node('idsq_probe', context=ros.context))
        self.estimates: dict[int, Odometry] = {}
        self.events: list[IdsqLeaderEvent] = []
        self.led: dict[int, int] = {}  # step → leader, from /idsq/leader
        self.warnings: list[Log] = []
        self.probe.create_subscription(Odometry, IDSQ_ESTIMATE, self._on_estimate, ESTIMATE_QOS)
        self.probe.create_subscription(tm.IdsqLeaderEvent, IDSQ_LEADER, self._on_leader, ESTIMATE_QOS)
        self.probe.create_subscription(Log, '/rosout', self._on_log,
                                       QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE))
        self.clock = self.probe.create_publisher(Clock, CLOCK, CLOCK_QOS)
        self.step = -1
        assert ros.spin_until(lambda: all(s.layout is not None for s in self.sensors.values())
                              and all(p.get_subscription_count() > 0 for p in self.vehicle.pub_readings)
                              and self.estimates_matched(), timeout=20), 'network not ready'

    def estimates_matched(self) -> bool:
        return all(s.pub_est.get_subscription_count() > 0 for s in self.sensors.values())

    def _on_estimate(self, msg: Odometry) -> None:
        step = step_of_stamp(stamp_to_sec(msg.header.stamp), DT, EPOCH)
        assert step not in self.estimates, f'two estimates for step {step}'
        self.estimates[step] = msg

    def _on_leader(self, msg: tm.IdsqLeaderEvent) -> None:
        e = IdsqLeaderEvent.from_msg(msg)
        self.events.append(e)
        if e.event == 'step':
            self.led[e.step] = e.leader

    def _on_log(self, msg: Log) -> None:
        if msg.level >= Log.WARN:
            self.warnings.append(msg)

    def run_to(self, step: int, timeout: float = 10.0) -> None:
        """Advance /clock one tracker step at a time until the estimate of ``step`` is in."""
        while self.step < step:
            self.step += 1
            self.clock.publish(Clock(clock=sec_to_stamp(EPOCH + (self.step + 1) * DT)))
            s = self.step
            assert self.ros.spin_until(lambda s=s: s in self.estimates and s in self.led, timeout=timeout), \
                f'no estimate of step {s}'

    def track(self) -> tuple[np.ndarray, np.ndarray]:
        steps = sorted(self.estimates)
        assert steps == list(range(len(steps)))
        states = [odometry_to_cv_state(self.estimates[s]) for s in steps]
        return (np.array([x[[0, 2]] for _, x, _ in states]),
                np.array([xy_block(self.estimates[s].pose.covariance) for s in steps]))

    def destroy(self, name: str) -> None:
        node = self.nodes.pop(name)
        self.sensors.pop(node.id)
        self.ros.nodes.remove(node)
        self.ros.executor.remove_node(node)
        node.destroy_node()


def _scenario_file(path: Path, seed: int, n_sensors: int, **kw) -> Path:
    path.write_text(scenario_yaml(seed=seed, n_sensors=n_sensors, **kw))
    return path


@pytest.fixture(scope='module')
def k8_file(tmp_path_factory) -> Path:
    return _scenario_file(tmp_path_factory.mktemp('idsq') / 'idsq8.yaml', 1, 8, duration=K8_STEPS * DT, rate=2.0)


def _error(means: np.ndarray, n_sensors: int = 24, seed: int = 1) -> np.ndarray:
    truth = scenario_of(seed, n_sensors, 0.3)[2][:len(means)]
    return np.hypot(*(means - truth).T)


# --- configuration and messages ------------------------------------------------------------------------

def test_scenario_file_matches_the_layout_generator(repo):
    """config/idsq.yaml's sensor entries are the seeded §5.1 layout vehicle_sim publishes."""
    doc = yaml.safe_load((repo / 'config/idsq.yaml').read_text())
    seed = doc['/**']['ros__parameters']['seed']
    vp = node_params(doc, 'vehicle_sim')
    _, layout, _ = scenario_of(seed, vp['n_sensors'], vp['doa_fraction'])
    specs = [s for s in load_scenario(str(repo / 'config/idsq.yaml')).nodes if s.executable != 'vehicle_sim']
    assert len(specs) == layout.n == 24
    for spec in specs:
        p = node_params(doc, spec.name)
        assert spec.executable == f'{p["type"]}_sensor'
        assert p['position'] == layout.positions[p['id']].tolist()  # exact (repr round trip)
        assert (p['type'] == 'doa') == bool(layout.is_doa[p['id']])


def test_layout_cloud_round_trip_is_exact():
    _, layout, _ = scenario_of(3, 12, 0.5)
    back = cloud_to_layout(layout_to_cloud(0.0, layout), 40.0)
    np.testing.assert_array_equal(back.positions, layout.positions)
    np.testing.assert_array_equal(back.is_doa, layout.is_doa)
    assert all(np.array_equal(a, b) for a, b in zip(back.neighbours, layout.neighbours, strict=True))


# --- the network in one process -------------------------------------------------------------------------

def test_network_tracks_the_vehicle_and_equals_the_core_loop(ros, repo):
    net = Network(ros, repo / 'config/idsq.yaml')
    n_steps = net.vehicle.n_steps
    net.run_to(n_steps - 1)
    means, covs = net.track()
    ref_means, ref_covs, ref_leaders = reference_track(1, 24, n_steps)
    np.testing.assert_array_equal(means, ref_means)
    np.testing.assert_array_equal(covs, ref_covs)
    assert [e.leader for e in net.events if e.event == 'step'] == ref_leaders
    err = _error(means)
    print(f'K=24 in-process: RMSE {np.sqrt(np.mean(err ** 2)):.2f} m, max {err.max():.2f} m, '
          f'{len(set(ref_leaders))} leaders')
    # The uniform belief's centroid (the field centre) is 62 m off on average along this track: the
    # network must do far better, and never lose the vehicle.
    assert np.sqrt(np.mean(err ** 2)) < 35.0 and err.max() < 80.0, np.round(err, 1)
    assert not any(e.event != 'step' for e in net.events)
    assert all(s.refused == s.timeouts == s.nacks == 0 for s in net.sensors.values())



def _assert_recorded_track(bag, n_steps: int, in_means, in_covs, log: str) -> None:
    """The bag's /idsq/estimate: one per step 0..n-1, means and x/y covariances equal bit for bit."""
    steps, means, covs = recorded_track(bag, DT)
    assert steps == list(range(n_steps)), (steps, log[-6000:])
    np.testing.assert_array_equal(means, in_means)
    np.testing.assert_array_equal(covs, in_covs)


def _assert_protocol_decodes_with_rosbags(bag, n_steps: int) -> None:
    """The bag's handoffs, acks and leader events, decoded by rosbags from the schemas the bag embeds
    (what Foxglove has): one step event per step, one handoff per led step (the last one's too) with
    consistent arrays, each acknowledged."""
    store = get_typestore(Stores.ROS2_JAZZY)
    got: dict[str, list] = {}
    with Reader(bag) as reader:
        conns = [c for c in reader.connections if c.msgtype.startswith('track_msgs/')]
        for conn in conns:
            store.register({k: v for k, v in get_types_from_msg(conn.msgdef.data, conn.msgtype).items()
                            if k not in store.fielddefs})
        for conn, _, raw in reader.messages(connections=conns):
            got.setdefault(conn.msgtype, []).append((conn.topic, store.deserialize_cdr(raw, conn.msgtype)))
    handoffs = got.get('track_msgs/msg/IdsqHandoff', [])
    assert len(handoffs) == n_steps and all(re.match(IDSQ_HANDOFF_REGEX, t) for t, _ in handoffs), got.keys()
    assert all(h.version == h.VERSION_GRID and len(h.cells) == len(h.mass) > 0 and f'sensor_{h.receiver}/' in t
               for t, h in handoffs)
    acks = [a for _, a in got.get('track_msgs/msg/IdsqAck', [])]
    assert len(acks) == n_steps and all(a.accepted and a.reason == '' for a in acks)
    assert sorted((a.step, a.sender, a.receiver) for a in acks) == sorted((h.step, h.sender, h.receiver)
                                                                         for _, h in handoffs)
    steps = [e.step for _, e in got.get('track_msgs/msg/IdsqLeaderEvent', []) if e.event == e.STEP]
    assert sorted(steps) == list(range(n_steps))

def test_one_process_per_sensor_gives_the_same_estimates(ros, k8_file, tmp_path, env_factory):
    """K = 8, 20 steps: the launcher with --processes records exactly the in-process estimates."""
    net = Network(ros, k8_file)
    net.run_to(K8_STEPS - 1)
    in_means, in_covs = net.track()
    ref_means, ref_covs, _ = reference_track(1, 8, K8_STEPS)
    np.testing.assert_array_equal(in_means, ref_means)
    np.testing.assert_array_equal(in_covs, ref_covs)
    proc = subprocess.run([sys.executable, '-m', 'track_nodes.launch', str(k8_file), '--processes',
                           '--record', 'mp'], cwd=tmp_path, env=env_factory(), capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0, proc.stderr[-3000:]
    _assert_recorded_track(tmp_path / 'bags/mp', K8_STEPS, in_means, in_covs, proc.stdout + proc.stderr)
    assert f'idsq: {K8_STEPS} estimates matched to truth' in proc.stdout and 're-selections 0' in proc.stdout
    res = check_bag(tmp_path / 'bags/mp')  # issue 19: layout and belief clouds with x, y, z; planar covariances
    # two layouts: stamped 0 (origin pending) before the clock started, then stamped with the origin
    assert res.ok and res.checked[IDSQ_LAYOUT] == 2 and res.checked[IDSQ_BELIEF] == K8_STEPS, res.problems
    assert res.checked[IDSQ_ESTIMATE] == K8_STEPS
    assert check_frames(tmp_path / 'bags/mp', stamps=True) == []
    _assert_protocol_decodes_with_rosbags(tmp_path / 'bags/mp', K8_STEPS)


# --- across simulated hosts (issue 15, part 1) -----------------------------------------------------------

# Runs where the machine allows simulated hosts (root and ip netns; TRACK_TEST_HOSTS=0 opts out) and
# skips with the reason elsewhere. It was opt-in while it failed about 1 run in 3 on a loaded 2-core
# machine (issue 15); the three causes and what became of them:
# - The step origin: vehicle_sim fixes it at its first /clock reading, and with 25 processes on 2 cores
#   its first callback ran up to 2 s after the clock started: the origin came a second or two late and
#   the run ended 2-4 steps before the track (16-18 of 20 estimates; 5 of 6 runs on a quiet machine).
#   Fixed: the launcher holds /clock at the epoch while discovery settles (launch/launcher.py).
# - CPU at the stop: 25 processes finalizing CPython at once were killed as hung. Fixed: node processes
#   skip the finalization, and the launcher kills only children idle for 3 s (launch/processes.py).
# - Fast DDS 2.14.5: entity and participant deletion can hang (set_listener spinning in
#   destroy_participant while a discovery callback of a peer's removal waits for a lock, or
#   destroy_subscription blocking idle; cf. eProsima/Fast-DDS#6513 and #6502). Not ours to fix: node
#   processes delete their DDS entities under a 5 s alarm after their own cleanup
#   (base/teardown.py), and the launcher names such an end without failing the run.
HOSTS_REASON = ('opted out: TRACK_TEST_HOSTS=0' if os.environ.get('TRACK_TEST_HOSTS') == '0'
                else unavailable())
HOST_STEPS = 20  # 10 s of config/idsq.yaml (K = 24, 25 processes)


@pytest.mark.skipif(HOSTS_REASON is not None, reason=f'no simulated hosts: {HOSTS_REASON}')
def test_idsq_over_three_hosts_gives_the_in_process_track(ros, repo, tmp_path, env_factory):
    """config/idsq.yaml, 20 steps, 25 processes over 3 network namespaces (--hosts 3): the recorded
    estimates equal, bit for bit, the in-process network's with the same seed."""
    net = Network(ros, repo / 'config/idsq.yaml')
    net.run_to(HOST_STEPS - 1)
    in_means, in_covs = net.track()
    proc = subprocess.Popen([sys.executable, '-m', 'track_nodes.launch', str(repo / 'config/idsq.yaml'),
                             '--processes', '--hosts', '3', '--duration', str(HOST_STEPS * DT), '--record', 'h3'],
                            cwd=tmp_path, env=env_factory(), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, start_new_session=True)
    out, err = '', ''
    try:
        out, err = proc.communicate(timeout=300)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGTERM)  # the launcher stops its children and removes the hosts
        try:
            out, err = proc.communicate(timeout=60)
        except subprocess.TimeoutExpired:
            proc.kill()
            out, err = proc.communicate()
    finally:
        tag = re.search(r'hosts: 3 namespaces (\S+)-\*', out or '')
        left = remove_leftovers(tag.group(1)) if tag else []
    assert tag, (out[-2000:], err[-3000:])
    assert left == [], f'namespaces left behind: {left}'
    assert proc.returncode == 0, err[-3000:]
    print(re.search(r'hosts: .*', out).group(0), f"; DDS teardown alarms: {err.count('its DDS teardown')}")
    _assert_recorded_track(tmp_path / 'bags/h3', HOST_STEPS, in_means, in_covs, out + err)
    assert f'idsq: {HOST_STEPS} estimates matched to truth' in out and 're-selections 0' in out


# --- leader failure --------------------------------------------------------------------------------------

def test_killing_the_next_leader_mid_track_keeps_tracking(ros, tmp_path):
    """K = 16 (seed 1): the sensor that would lead step 14 is destroyed after step 12."""
    kill_step, end, k = 14, 34, 16
    _, _, leaders = reference_track(1, k, end)
    victim = leaders[kill_step]  # receives the handoff of step kill_step - 1
    assert leaders[kill_step - 1] != victim
    net = Network(ros, _scenario_file(tmp_path / 'idsq16.yaml', 1, k, ack_timeout=0.3))
    net.run_to(kill_step - 2)
    net.destroy(f'sensor_{victim}')
    net.run_to(end)
    means, _ = net.track()
    np.testing.assert_array_equal(means[:kill_step - 1], reference_track(1, k, kill_step - 1)[0])
    resel = [e for e in net.events if e.event == 'reselect']
    assert resel and resel[0].failed == victim and resel[0].reason == 'timeout'
    assert resel[0].step == kill_step - 1 and resel[0].leader == leaders[kill_step - 1]
    step_leaders = [e.leader for e in net.events if e.event == 'step']
    assert victim not in step_leaders[kill_step:] and len(step_leaders) == end + 1
    assert any('no ack from sensor' in w.msg and f'sensor {victim}' in w.msg for w in net.warnings)
    err = _error(means, k)
    print(f'after killing sensor {victim}: error steps {kill_step}..{end}: mean {err[kill_step:].mean():.1f} m, '
          f'max {err[kill_step:].max():.1f} m; {len(resel)} re-selection(s)')
    assert err[kill_step:].mean() < 35.0 and err[kill_step:].max() < 80.0, np.round(err, 1)


# --- malformed handoffs ----------------------------------------------------------------------------------

def _bad_handoffs(sender: int, receiver: int) -> dict[str, tuple[tm.IdsqHandoff, str]]:
    grid = GridSpec.for_field(150.0, 250.0, 5.0)
    idx = np.array([10, 11, 12], dtype=np.int64)

    def msg(g, p, **fields):
        m = IdsqHandoff.from_handoff(3.0, Handoff(4, sender, receiver, g, idx, np.asarray(p, dtype=float))).to_msg()
        for k, v in fields.items():
            setattr(m, k, v)
        return m

    return {
        'nan': (msg(grid, [0.5, math.nan, 0.5]), 'non-finite'),
        'negative': (msg(grid, [0.7, -0.2, 0.5]), 'negative mass'),
        'grid': (msg(GridSpec.for_field(150.0, 250.0, 10.0), [0.2, 0.3, 0.5]), 'wrong grid'),
        'version': (msg(grid, [0.2, 0.3, 0.5], version=9), 'unknown handoff version 9'),
        'lengths': (msg(grid, [0.2, 0.3, 0.5], mass=[0.5, 0.5]), '3 cells but 2 masses'),
    }


def test_malformed_handoffs_are_refused_with_a_warning_and_a_nack(ros, k8_file):
    net = Network(ros, k8_file)
    layout = net.vehicle.layout
    receiver = 0
    sender = int(layout.neighbours[receiver][0])
    acks: list[tm.IdsqAck] = []
    net.probe.create_subscription(tm.IdsqAck, idsq_ack_topic(sender), acks.append, HANDOFF_QOS)
    pub = net.probe.create_publisher(tm.IdsqHandoff, idsq_handoff_topic(receiver), HANDOFF_QOS)
    assert ros.spin_until(lambda: pub.get_subscription_count() > 0)
    node = net.sensors[receiver]
    before = _ledger_state(node)
    bad = _bad_handoffs(sender, receiver)
    for i, (kind, (msg, words)) in enumerate(bad.items()):
        pub.publish(msg)
        assert ros.spin_until(lambda i=i: node.refused == i + 1), kind
        assert ros.spin_until(lambda i=i, w=words: any(w in m.msg and 'refused:' in m.msg
                                                       for m in net.warnings[i:])), kind
    assert ros.spin_until(lambda: len(acks) == len(bad))  # a typed handoff always names its sender: all answered
    replies = [IdsqAck.from_msg(a) for a in acks]
    assert [a.result for a in replies] == ['nack'] * len(bad)
    assert all(w in a.reason for a, (_, w) in zip(replies, bad.values(), strict=True))
    assert node.pending is None and not node.led and _ledger_state(node) == before
    mine = [w for w in net.warnings if w.name == f'sensor_{receiver}']
    assert len(mine) == len(bad) and all(m.msg.startswith(f'{idsq_handoff_topic(receiver)}: refused: ')
                                         and '\n' not in m.msg for m in mine)
    # the impersonated sender hears nacks for handoffs it never sent, and says so (one line: throttled)
    assert all(w.name == f'sensor_{sender}' and 'late reply: nack' in w.msg for w in net.warnings if w not in mine)


def test_a_hostile_reply_or_revoke_changes_nothing(ros, k8_file):
    """A nack whose reason is no single line is refused (one throttled line); a revoke of a handoff the
    sensor never took, or addressed to another sensor, changes nothing."""
    net = Network(ros, k8_file)
    k, other = 0, int(net.vehicle.layout.neighbours[0][0])
    node = net.sensors[k]
    before = _ledger_state(node)
    ack = net.probe.create_publisher(tm.IdsqAck, idsq_ack_topic(k), HANDOFF_QOS)
    revoke = net.probe.create_publisher(tm.IdsqRevoke, idsq_revoke_topic(k), HANDOFF_QOS)
    assert ros.spin_until(lambda: ack.get_subscription_count() > 0 and revoke.get_subscription_count() > 0)
    for _ in range(3):
        ack.publish(IdsqAck.reply(0, k, other, 'two\nlines').to_msg())
    revoke.publish(IdsqRevoke(0, other, k).to_msg())  # nothing of step 0 from `other` held
    revoke.publish(IdsqRevoke(0, other, other).to_msg())  # not for this sensor: refused
    topic_ack, topic_revoke = node.resolved(idsq_ack_topic(k)), node.resolved(idsq_revoke_topic(k))
    want = {(topic_ack, 'reply'): 3, (topic_revoke, 'revoke of step'): 1}
    assert ros.spin_until(lambda: node.refusals.counts == want), node.refusals.counts
    assert _ledger_state(node) == before

    def new_kinds() -> list[str]:  # one line per kind at once, the rest summed up later (/rosout lags)
        return [w.msg for w in net.warnings if w.name == f'sensor_{k}' and 'new kind of refusal' in w.msg]
    assert ros.spin_until(lambda: len(new_kinds()) >= 2), new_kinds()
    assert len(new_kinds()) == 2 and any('idsq ack: reason must be one printable line' in m for m in new_kinds())


def test_a_refusing_sensor_makes_the_sender_reselect(ros, k8_file):
    """A sensor on another grid refuses every handoff ("wrong grid"): its senders re-select and the
    track goes on without it."""
    _, _, leaders = reference_track(1, 8, K8_STEPS)
    refuser = next(k for k in leaders[1:] if k != leaders[0])  # first sensor the track hands to
    net = Network(ros, k8_file, {f'sensor_{refuser}': [Parameter('cell', value=10.0)]})
    net.run_to(K8_STEPS - 1)
    resel = [e for e in net.events if e.event == 'reselect']
    assert resel and all(e.failed == refuser and e.reason == 'nack' for e in resel)
    assert refuser not in [e.leader for e in net.events if e.event == 'step']
    assert net.sensors[refuser].refused == len(resel) and sum(s.nacks for s in net.sensors.values()) == len(resel)
    assert any('wrong grid' in w.msg for w in net.warnings if w.name == f'sensor_{refuser}')
    assert any('refused the handoff' in w.msg for w in net.warnings)


# --- parameters and layout checks ------------------------------------------------------------------------

@pytest.mark.parametrize(('cls_name', 'over', 'words'), [
    ('DoaSensorNode', {'type': 'acoustic'}, ["type='acoustic'", 'doa_sensor', "allowed 'doa'"]),
    ('AcousticSensorNode', {'position': [1.0, math.nan]}, ['position', 'nan', 'allowed']),
    ('AcousticSensorNode', {'ack_timeout': 0.0}, ['ack_timeout', 'allowed']),
    ('AcousticSensorNode', {'selection': 'best'}, ['selection', 'best', 'mi']),
])
def test_bad_sensor_parameters_stop_the_node_with_one_line(ros, cls_name, over, words):
    from track_nodes.base import ParameterError
    from track_nodes.idsq import sensor

    cls = getattr(sensor, cls_name)
    with pytest.raises(ParameterError) as exc:
        cls(context=ros.context, parameter_overrides=[Parameter(k, value=v) for k, v in over.items()])
    assert '\n' not in str(exc.value) and all(w in str(exc.value) for w in words), str(exc.value)


def test_sensor_disagreeing_with_the_layout_stays_passive(ros):
    from track_nodes.idsq.sensor import AcousticSensorNode
    from track_nodes.idsq.vehicle_sim import VehicleSimNode

    vehicle = ros.add(VehicleSimNode(context=ros.context, parameter_overrides=[Parameter('seed', value=1),
                                                                              Parameter('n_sensors', value=8)]))
    k = int(np.flatnonzero(~vehicle.layout.is_doa)[0])
    x, y = vehicle.layout.positions[k]
    node = ros.add(AcousticSensorNode(context=ros.context, parameter_overrides=[
        Parameter('id', value=k), Parameter('position', value=[float(x) + 1.0, float(y)])]))
    assert ros.spin_until(lambda: node.disabled, timeout=10)
    assert node.layout is None


# --- protocol helpers (no ROS graph) ------------------------------------------------------------------

def test_header_peek():
    """(The step stamps, draws and handoff order are tested with the ledger, test/unit/track_core/idsq.)"""
    from track_core.idsq.handoff import peek_header

    data = encode_handoff(Handoff(9, 2, 4, GridSpec.for_field(), np.array([1, 5]), np.array([0.25, 0.75])))
    assert peek_header(data) == (2, 4, 9) and peek_header(b'IDSQ' + bytes(20)) is None and peek_header(b'x') is None


# --- protocol windows (issue 13, defect 3) ------------------------------------------------------------------

def _ledger_state(node) -> bytes:
    """The sensor's ledger, every field but the refusal counter, as bytes (arrays included)."""
    import pickle
    return pickle.dumps({k: v for k, v in vars(node.core).items() if k not in ('refused', 's', 'layout')})


def test_a_handoff_of_step_0xffffffff_is_refused_and_the_sensor_still_leads(ros, k8_file):
    """Before issue 13 the sensor took it, waited for a truth that never comes and refused every real
    handoff as busy: its senders re-selected around it for the rest of the run."""
    means, _, leaders = reference_track(1, 8, K8_STEPS)
    j = next(j for j in range(5, K8_STEPS) if leaders[j] != leaders[4])  # not holding step 4 at the flood
    receiver, sender = leaders[j], leaders[j - 1]
    net = Network(ros, k8_file)
    net.run_to(3)
    node = net.sensors[receiver]
    assert ros.spin_until(lambda: all(3 in s.core.readings and not s.core.outgoing for s in net.sensors.values()))
    before = _ledger_state(node)
    acks: list = []  # the replies to the bad handoff (transient-local also brings older ones)
    net.probe.create_subscription(tm.IdsqAck, idsq_ack_topic(sender), lambda m: acks.extend(
        [m] if m.step == 0xFFFFFFFF else []), HANDOFF_QOS)
    pub = net.probe.create_publisher(tm.IdsqHandoff, idsq_handoff_topic(receiver), HANDOFF_QOS)
    assert ros.spin_until(lambda: pub.get_subscription_count() > 0)
    grid = GridSpec.for_field(150.0, 250.0, 5.0)
    bad = Handoff(0xFFFFFFFF, sender, receiver, grid, np.array([5, 6]), np.array([0.5, 0.5]))
    for i in range(20):  # a flood (the handoff QoS keeps 4: one at a time): counted, one log line
        pub.publish(IdsqHandoff.from_handoff(0.0, bad).to_msg())
        assert ros.spin_until(lambda i=i: node.refused == i + 1 and len(acks) == i + 1, timeout=30)
    assert all(not a.accepted and 'window' in a.reason and a.header.stamp.sec == 0 for a in acks)
    assert _ledger_state(node) == before and node.pending is None
    assert node.refusals.counts == {(idsq_handoff_topic(receiver), 'window'): 20}
    assert len([w for w in net.warnings if w.name == f'sensor_{receiver}']) == 1
    net.run_to(K8_STEPS - 1)  # the track goes on through the receiver, exactly as the core loop
    assert net.led[j] == receiver and not [e for e in net.events if e.event == 'reselect']
    np.testing.assert_array_equal(net.track()[0], means)
    assert [e.leader for e in net.events if e.event == 'step'] == leaders


# --- readings: missing, late, replayed, brought by the user -------------------------------------------------

def test_no_sensor_subscribes_to_a_truth(ros, k8_file):
    net = Network(ros, k8_file)
    for k, node in net.sensors.items():
        subs = {t for t, _ in node.get_subscriber_names_and_types_by_node(node.get_name(), node.get_namespace())}
        assert idsq_reading_topic(k) in subs and not any('truth' in t for t in subs), subs
    assert net.vehicle.count_subscribers(IDSQ_TRUTH) == 0


def test_a_missing_reading_is_led_predict_only_and_a_late_one_is_dropped(ros, k8_file):
    """The reading of step 6 never reaches its leader: after reading_timeout (0.3 s) it leads the step
    predict-only (updated false, z NaN) and hands on; the track before it is the core loop's, after it
    still near the vehicle. The reading sent afterwards is refused as late, once, and changes nothing."""
    gap = 6
    ref_means, _, leaders = reference_track(1, 8, K8_STEPS)
    victim = leaders[gap]
    over = [Parameter('reading_timeout', value=0.3)]
    net = Network(ros, k8_file, {f'sensor_{k}': over for k in range(8)})
    publish = net.vehicle._publish_readings
    dropped = []

    def dropping(t, readings):
        dropped.extend((t, r) for r in readings if (r.step, r.sensor) == (gap, victim))
        publish(t, [r for r in readings if (r.step, r.sensor) != (gap, victim)])

    net.vehicle._publish_readings = dropping
    net.run_to(K8_STEPS - 1)
    means, _ = net.track()
    node = net.sensors[victim]
    assert dropped and node.missed == 1 and node.late == 0 and node.core.missed == [gap]
    np.testing.assert_array_equal(means[:gap], ref_means[:gap])
    (ev,) = [e for e in net.events if e.event == 'step' and e.step == gap]
    assert ev.leader == victim and ev.updated is False and math.isnan(ev.z)
    assert any(f'no reading of step {gap}' in w.msg for w in net.warnings if w.name == f'sensor_{victim}')
    err = _error(means, 8)
    assert err[gap:].mean() < 35.0 and err[gap:].max() < 80.0, np.round(err, 1)
    before = _ledger_state(node)
    t, r = dropped[0]
    from track_msgs_py.records.idsq import IdsqReading
    late = net.probe.create_publisher(tm.IdsqReading, idsq_reading_topic(victim), HANDOFF_QOS)
    assert ros.spin_until(lambda: late.get_subscription_count() > 0)
    late.publish(IdsqReading.of_reading(t, r).to_msg())
    assert ros.spin_until(lambda: node.late == 1)
    assert node.refusals.counts == {(node.resolved(idsq_reading_topic(victim)), 'late'): 1}
    assert _changed(before, node) == ['late']  # the counter only


def test_a_hostile_reading_is_refused_and_changes_nothing(ros, k8_file):
    """NaN, another sensor's, the wrong type, off the step grid, absurdly far ahead: one throttled line
    each kind, counted, the ledger unchanged."""
    from track_msgs_py.records.idsq import IdsqReading
    net = Network(ros, k8_file)
    net.run_to(1)
    k = int(np.flatnonzero(net.vehicle.layout.is_doa)[0])
    node = net.sensors[k]
    assert ros.spin_until(lambda: all(1 in s.core.readings and not s.core.outgoing for s in net.sensors.values()))
    before = _ledger_state(node)
    pub = net.probe.create_publisher(tm.IdsqReading, idsq_reading_topic(k), HANDOFF_QOS)
    assert ros.spin_until(lambda: pub.get_subscription_count() > 0)
    t = EPOCH + 3 * DT
    bad = [IdsqReading(t, k, True, 3.0, math.nan, 0.05).to_msg(),           # NaN direction
           IdsqReading(t, k + 1, True, 3.0, 0.5, 0.05).to_msg(),            # another sensor's
           IdsqReading(t, k, False, 3.0).to_msg(),                          # an acoustic reading
           IdsqReading(t + 0.1, k, True, 3.0, 0.5, 0.05).to_msg(),          # off the step grid
           IdsqReading(EPOCH + 1e6, k, True, 3.0, 0.5, 0.05).to_msg()]      # 2e6 steps ahead
    for m in bad:
        pub.publish(m)
    assert ros.spin_until(lambda: node.refusals.total() == len(bad)), node.refusals.counts
    kinds = {kind for _, kind in node.refusals.counts}
    assert kinds == {'idsq reading', 'sensor_id', 'type', 'header.stamp', 'step'}, kinds
    assert _ledger_state(node) == before, _changed(before, node)


def _changed(before: bytes, node) -> list[str]:
    import pickle
    old, new = pickle.loads(before), pickle.loads(_ledger_state(node))
    return [k for k in new if pickle.dumps(old.get(k)) != pickle.dumps(new[k])]


def test_recorded_readings_replay_bit_for_bit_into_a_fresh_network(ros, k8_file, tmp_path):
    """K = 8, 20 steps: the layout and the readings recorded (the project's recorder, wall-time stamps)
    from a run with vehicle_sim, played with track-play into fresh sensor nodes of the same scenario
    file and no simulator: the same /idsq/estimate, means and covariances bit for bit."""
    from track_nodes.bag.recorder import RecorderNode

    net = Network(ros, k8_file)
    bag = tmp_path / 'readings'
    rec = ros.add(RecorderNode(context=ros.context, parameter_overrides=[
        Parameter('bag', value=str(bag)), Parameter('flush_period', value=0.2), Parameter('clock', value='wall'),
        Parameter('regex', value=r'^/idsq/(layout|sensor_\d+/reading)$')]))
    topics = {IDSQ_LAYOUT, *(idsq_reading_topic(k) for k in range(8))}
    assert ros.spin_until(lambda: topics <= set(rec.subscriptions_by_topic), timeout=20)
    net.run_to(K8_STEPS - 1)
    first = {k: (v.pose.pose.position.x, v.pose.pose.position.y, tuple(v.pose.covariance))
             for k, v in net.estimates.items()}
    assert ros.spin_until(lambda: all(rec.message_counts().get(idsq_reading_topic(k), 0) >= K8_STEPS
                                      for k in range(8)) and rec.message_counts().get(IDSQ_LAYOUT, 0) >= 1), \
        rec.message_counts()
    for node in [*net.nodes.values(), rec]:  # the first network and the simulator go; the bag is closed
        ros.nodes.remove(node)
        ros.executor.remove_node(node)
        node.destroy_node()
    fresh = {}
    for spec in load_scenario(str(k8_file)).nodes:
        if spec.executable != 'vehicle_sim':
            fresh[spec.name] = ros.add(spec.node_class()(
                node_name=spec.name, context=ros.context, parameter_overrides=[Parameter('use_sim_time', value=True)],
                cli_args=['--ros-args', '--params-file', str(k8_file)]))
    net.estimates.clear()  # the probe's collector takes the fresh network's estimates
    player = subprocess.Popen([sys.executable, '-m', 'track_nodes.bag.player', str(bag), '--rate', '2',
                               '--wait-subscribers', '60'], env=ros.env, stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True)
    try:
        assert ros.spin_until(lambda: len(net.estimates) >= K8_STEPS, timeout=120), sorted(net.estimates)
    finally:
        _, err = player.communicate(timeout=120)
    assert player.returncode == 0, err[-2000:]
    got = {k: (v.pose.pose.position.x, v.pose.pose.position.y, tuple(v.pose.covariance))
           for k, v in net.estimates.items()}
    assert got == first
    assert all(n.missed == n.late == n.unheard == n.refused == 0 for n in fresh.values())


def _usage_example(repo) -> str:
    """The adapter example of docs/USAGE.md's IDSQ section (its one python block)."""
    text = (repo / 'docs/USAGE.md').read_text()
    section = text.split('## Bring your own sensor: the IDSQ field', 1)[1].split('\n## ', 1)[0]
    return section.split('```python\n', 1)[1].split('```', 1)[0]


def test_the_usage_example_front_end_gets_a_track_without_any_truth(ros, repo, tmp_path):
    """docs/USAGE.md's example: microphones and a DOA front end giving unit direction vectors, adapted to
    IdsqReading for a field of 8 sensor nodes (their default parameters, volatile readings); no truth
    topic exists, and the network tracks the example's source."""
    import ast

    code = _usage_example(repo)
    script = tmp_path / 'front_end.py'
    script.write_text(code)
    tree = ast.parse(code)
    consts = {t.id: ast.literal_eval(n.value) for n in tree.body if isinstance(n, ast.Assign)
              for t in n.targets if isinstance(t, ast.Name) and t.id in ('FIELD', 'STEPS', 'DT', 'SPEED')}
    from track_nodes.idsq.sensor import AcousticSensorNode, DoaSensorNode
    sensors = {}
    for k, (x, y, kind) in enumerate(consts['FIELD']):
        cls = DoaSensorNode if kind == 'doa' else AcousticSensorNode
        sensors[k] = ros.add(cls(node_name=f'sensor_{k}', context=ros.context, parameter_overrides=[
            Parameter('id', value=k), Parameter('position', value=[float(x), float(y)]),
            Parameter('dt', value=float(consts['DT']))]))
    probe = ros.add(Node('byo_probe', context=ros.context))
    est: dict[int, np.ndarray] = {}
    probe.create_subscription(Odometry, IDSQ_ESTIMATE, lambda m: est.update(
        {len(est): np.array([m.pose.pose.position.x, m.pose.pose.position.y])}), ESTIMATE_QOS)
    proc = subprocess.Popen([sys.executable, str(script)], env=ros.env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        assert ros.spin_until(lambda: len(est) >= consts['STEPS'] or proc.poll() not in (None, 0), timeout=120), \
            (len(est), proc.poll())
    finally:
        _, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err[-2000:]
    topics = {t for t, _ in probe.get_topic_names_and_types()}
    assert not any('truth' in t for t in topics), topics
    truth = np.array([[75.0, consts['SPEED'] * consts['DT'] * s] for s in range(consts['STEPS'])])
    err_m = np.hypot(*(np.array([est[s] for s in range(consts['STEPS'])]) - truth).T)
    print(f'usage example: {len(est)} estimates, RMSE {np.sqrt(np.mean(err_m ** 2)):.1f} m, max {err_m.max():.1f} m')
    assert np.sqrt(np.mean(err_m[4:] ** 2)) < 30.0, np.round(err_m, 1)
    assert all(n.missed == n.late == n.refused == 0 for n in sensors.values())

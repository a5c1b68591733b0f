"""Sonar scenario: smart_target, sonar_sim and sonar_observer in-process and through the launcher.

- In-process, /clock driven by the test: the estimate converges near the truth, and the three nodes
  reproduce, bit for bit, the core-only closed loop with the same seeds (the nodes add no maths
  and follow the ordering rule of ``track_experiments.sonar.experiments.run_closed_loop``).
- Launcher: ``config/sonar.yaml`` recorded for 20 s; replaying the recorded contacts and navigation
  with the player into a fresh ``sonar_observer`` with the same parameters reproduces every recorded
  estimate and request.
- Started by hand, in any order and 3 s apart on wall time, the three processes lock-step.
- Bad parameters stop a node at start with one line (through the ros2-run shim, exit code 2).
"""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from geometry_msgs.msg import PointStamped
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.serialization import deserialize_message
from rclpy.time import Time
from rosbags.rosbag2 import Reader
from rosgraph_msgs.msg import Clock

from track_core.sonar import (
    ObserverTrajectory,
    Scenario,
    SensorMode,
    SmartTarget,
    SmartTargetParams,
    SonarParams,
    make_tracker,
)
from track_core.sonar.contacts import paper_reading, simulated_contact
from track_msgs import msg as tm
from track_msgs_py.odometry import odometry_to_cv_state
from track_msgs_py.qos import CLOCK_QOS, ESTIMATE_QOS, STATIC_QOS, TRUTH_QOS
from track_msgs_py.records.sonar import SonarFilterStatus
from track_msgs_py.stamps import sec_to_stamp, stamp_to_ns
from track_msgs_py.topics import (
    CLOCK,
    SONAR_CONTACTS,
    SONAR_ESTIMATE,
    SONAR_MODE,
    SONAR_MODE_COMMAND,
    SONAR_OBSERVER,
    SONAR_PING,
    SONAR_TARGET_STATUS,
    SONAR_TRUTH,
    TF,
)
from track_nodes.bag.check import check_bag
from track_nodes.bag.frames import check_frames
from track_nodes.base import ParameterError
from track_nodes.base.scenario_file import node_params
from track_nodes.sonar.smart_target import SmartTargetNode
from track_nodes.sonar.sonar_observer import SonarObserverNode
from track_nodes.sonar.sonar_sim import SonarSimNode

STEPS = 40  # the paper's 40 s at T = 1 s
RECORD_S = 20


def _config(repo: Path) -> dict:
    return yaml.safe_load((repo / 'config/sonar.yaml').read_text())


def _node(ros, repo, cls, name, **over):
    params = [Parameter('use_sim_time', value=True), *[Parameter(k, value=v) for k, v in over.items()]]
    return ros.add(cls(node_name=name, context=ros.context, parameter_overrides=params,
                       cli_args=['--ros-args', '--params-file', str(repo / 'config/sonar.yaml')]))


class Sink:
    """Collects the sonar topics in a node of the test's context."""

    def __init__(self, ros, raw: bool = False) -> None:
        self.node = ros.add(Node('sonar_sink', context=ros.context))
        types = {SONAR_TRUTH: Odometry, SONAR_ESTIMATE: Odometry, SONAR_OBSERVER: Odometry,
                 SONAR_PING: PointStamped, SONAR_MODE: tm.SonarFilterStatus, SONAR_TARGET_STATUS: tm.SonarTargetStatus,
                 SONAR_CONTACTS: tm.SonarContact, SONAR_MODE_COMMAND: tm.SonarModeCommand}
        self.msgs: dict[str, list] = {t: [] for t in types}
        qos = {SONAR_TRUTH: TRUTH_QOS, SONAR_MODE_COMMAND: STATIC_QOS}  # transient-local, as published
        for topic, cls in types.items():
            self.node.create_subscription(cls, topic, self.msgs[topic].append, qos.get(topic, ESTIMATE_QOS))


def truth_x0(repo: Path) -> np.ndarray:
    return np.array(node_params(_config(repo), 'smart_target')['x0'])


def _reference_closed_loop(cfg: dict, steps: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, SmartTarget]:
    """The same closed loop with the core only (as run_closed_loop): estimates, covariances, modes."""
    tp, op, sp = node_params(cfg, 'smart_target'), node_params(cfg, 'sonar_observer'), node_params(cfg, 'sonar_sim')
    target = SmartTarget(np.array(tp['x0']), sonar=SonarParams(T=tp['period'], q_s=tp['q_s']), params=SmartTargetParams(
        p_max=tp['p_max'], r_50=tp['r_50'], width=tp['width'], evade_speed=tp['evade_speed'],
        max_turn_rate=math.radians(tp['max_turn_rate_deg']), max_accel=tp['max_accel'],
        quiet_period=tp['quiet_period'], naive=tp['naive']))
    r_tgt = np.random.default_rng(tp['seed'])
    sonar = SonarParams(T=op['period'], q_s=op['q_s'], sigma_b=math.radians(sp['sigma_b_deg']),
                        sigma_d=sp['sigma_d'], n_particles=op['n_particles'])
    r_noise = np.random.default_rng(np.random.SeedSequence(sp['seed']).spawn(2)[0])
    filter_ss = np.random.SeedSequence(op['seed']).spawn(2)[1]
    trk = make_tracker(op['tracker'], sonar, np.random.default_rng(filter_ss), P_D=op['P_D'], delta=op['delta'],
                       metric=op['metric'], regularize=op['regularize'])
    trk.initialize(np.array(op['prior_mean']), Scenario(prior_pos_std=op['prior_pos_std'],
                                                        prior_vel_std=op['prior_vel_std']).prior_cov)
    legs = tuple(zip(sp['legs'][::2], sp['legs'][1::2], strict=True))
    traj = ObserverTrajectory(start=tuple(sp['start']), speed=sp['speed'], heading0_deg=sp['heading0_deg'], legs=legs)
    means, covs, active = [], [], []
    pinged, obs_prev = False, np.zeros(2)
    for k in range(1, steps + 1):
        x = target.step(r_tgt, pinged, obs_prev)  # hears the ping of t_{k-1}, moves to t_k
        obs = traj.position(k * op['period'])
        mode = trk.next_mode
        c = simulated_contact(r_noise, k * 10**9, x, obs, mode, sonar)  # a true bearing: REP-103 yaw in map
        est = trk.step(paper_reading(c), mode, obs, R=c.R)
        means.append(est.mean)
        covs.append(est.cov)
        pinged, obs_prev = mode is SensorMode.ACTIVE, obs
        active.append(pinged)
    return np.array(means), np.array(covs), np.array(active), target


@pytest.fixture
def in_process_run(ros, repo):
    """The three nodes in-process on sim time; the test publishes /clock and waits for each step."""
    target = _node(ros, repo, SmartTargetNode, 'smart_target')
    _node(ros, repo, SonarSimNode, 'sonar_sim')
    observer = _node(ros, repo, SonarObserverNode, 'sonar_observer')
    sink = Sink(ros)
    clock = ros.add(Node('test_clock', context=ros.context)).create_publisher(Clock, CLOCK, CLOCK_QOS)
    assert ros.spin_until(lambda: observer.pub_est.get_subscription_count() > 0
                          and target.pub_truth.get_subscription_count() > 1, timeout=10)
    for k in range(1, STEPS + 1):
        for t in (k - 0.5, k):  # half-step ticks: the timers never fire twice in one tick
            clock.publish(Clock(clock=sec_to_stamp(t)))
            # the target's step origin is the whole second of its first clock reading (t = 0.5)
            assert ros.spin_until(lambda t=t: observer.k >= math.floor(t) and len(sink.msgs[SONAR_OBSERVER])
                                  >= math.floor(t) and target.steps.origin == 0.0, timeout=10), \
                f'step at t={t} not taken'
    per_step = (SONAR_ESTIMATE, SONAR_TRUTH, SONAR_MODE, SONAR_OBSERVER, SONAR_TARGET_STATUS)
    assert ros.spin_until(lambda: all(len(sink.msgs[t]) >= STEPS for t in per_step)
                          and len(sink.msgs[SONAR_PING]) == observer.pings)
    return target, observer, sink


def test_estimate_converges_near_the_truth(in_process_run, repo):
    target, observer, sink = in_process_run
    truth = {stamp_to_ns(m.header.stamp): odometry_to_cv_state(m)[1] for m in sink.msgs[SONAR_TRUTH]}
    est = [odometry_to_cv_state(m) for m in sink.msgs[SONAR_ESTIMATE]]
    assert [round(t * 1e9) for t, _, _ in est] == [k * 10**9 for k in range(1, STEPS + 1)]
    err = np.array([np.hypot(*(truth[round(t * 1e9)] - x)[[0, 2]]) for t, x, _ in est])
    op = node_params(_config(repo), 'sonar_observer')
    prior_err = np.hypot(*(np.array(op['prior_mean']) - truth_x0(repo))[[0, 2]])  # ≈ 22 m
    # Table 1 sensors (σ_d = 5 m; 1° of bearing ≈ 8 m at 0.5 km) and the paper's RTAMS ≈ 8 m: the
    # last 10 s stay well inside the prior error, and within the filter's own covariance (NEES).
    print('position error per step [m]:', np.round(err, 2).tolist())
    assert np.sqrt(np.mean(err[-10:] ** 2)) < min(15.0, prior_err / 1.5), err
    nees = [(truth[round(t * 1e9)] - x)[[0, 2]] @ np.linalg.solve(P[np.ix_([0, 2], [0, 2])],
                                                                      (truth[round(t * 1e9)] - x)[[0, 2]])
            for t, x, P in est[-10:]]
    print('position NEES, last 10 steps:', np.round(nees, 2).tolist())
    assert np.mean(nees) < 2 * 13.8  # mean of 10 χ²(2) values; far above its 99.9% point only if broken
    pings = len(sink.msgs[SONAR_PING])
    assert 0 < pings < STEPS and pings == observer.pings
    assert target.target.pings == pings - (1 if observer.tracker.estimate.mode is SensorMode.ACTIVE else 0)


def test_nodes_equal_the_core_closed_loop(in_process_run, repo):
    """Same seeds, same ordering rule: the nodes' estimates are the core loop's, bit for bit."""
    target, _, sink = in_process_run
    means, covs, active, ref_target = _reference_closed_loop(_config(repo), STEPS)
    got = [odometry_to_cv_state(m) for m in sink.msgs[SONAR_ESTIMATE]]
    np.testing.assert_array_equal(np.array([x for _, x, _ in got]), means)
    pos = np.ix_([0, 2], [0, 2])
    np.testing.assert_array_equal(np.array([P[pos] for _, _, P in got]), covs[:, pos[0], pos[1]])
    ping_steps = [round(stamp_to_ns(m.header.stamp) / 1e9) for m in sink.msgs[SONAR_PING]]
    assert ping_steps == [k + 1 for k in np.flatnonzero(active)]
    assert (target.target.detections, target.target.mode) == (ref_target.detections, ref_target.mode)
    modes = [SonarFilterStatus.from_msg(m).mode for m in sink.msgs[SONAR_MODE]]
    assert modes == [SensorMode.ACTIVE if a else SensorMode.PASSIVE for a in active]


# --- launcher, recording and replay -------------------------------------------------------------

def _bag_msgs(bag: Path) -> dict[str, list]:
    from track_nodes.bag.api import msg_class

    out: dict[str, list] = {}
    with Reader(bag) as reader:
        for conn, _, raw in reader.messages():
            out.setdefault(conn.topic, []).append(deserialize_message(raw, msg_class(conn.msgtype)))
    return out


@pytest.fixture(scope='module')
def sonar_bag(tmp_path_factory, env_factory, repo):
    cwd = tmp_path_factory.mktemp('sonar_launch')
    cmd = [sys.executable, '-m', 'track_nodes.launch', str(repo / 'config/sonar.yaml'), '--record', 'sonar',
           '--duration', str(RECORD_S), '--rate', '20']
    proc = subprocess.run(cmd, cwd=cwd, env=env_factory(), capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    return cwd / 'bags/sonar', proc.stdout


def test_launcher_records_every_step_and_prints_the_summary(sonar_bag):
    bag, stdout = sonar_bag
    msgs = _bag_msgs(bag)
    for topic in (SONAR_TRUTH, SONAR_ESTIMATE, SONAR_OBSERVER, SONAR_MODE, SONAR_TARGET_STATUS):
        assert len(msgs[topic]) == RECORD_S, topic
    assert 0 < len(msgs[SONAR_PING]) < RECORD_S
    assert 'RTAMS' in stdout and f'pings emitted {len(msgs[SONAR_PING])}/{RECORD_S}' in stdout
    res = check_bag(bag)  # issue 19: planar covariances (estimate, truth, observer)
    assert res.ok and res.checked[SONAR_ESTIMATE] == RECORD_S and res.checked[SONAR_TRUTH] == RECORD_S, res.problems


def test_every_frame_of_the_recording_is_placed_in_map(sonar_bag):
    bag, _ = sonar_bag
    assert check_frames(bag, stamps=True) == []  # the observer's body frame on /tf; track ids are no frames
    assert len(_bag_msgs(bag)[TF]) == RECORD_S  # one per observer step, the first one too (advertised at start)


def test_replaying_the_measurements_reproduces_the_estimates(sonar_bag, ros, repo, prefix):
    """The recorded contacts and navigation, played with track-play into a fresh sonar_observer (same
    parameters and seed), give the recorded estimates, modes and requests exactly: the estimator depends
    on nothing but its seed and its measurements."""
    bag, _ = sonar_bag
    recorded = _bag_msgs(bag)
    observer = _node(ros, repo, SonarObserverNode, 'sonar_observer')
    sink = Sink(ros)
    player = subprocess.Popen([str(prefix / 'lib/track_nodes/player'), str(bag), '--rate', '10',
                               '--topics', SONAR_CONTACTS, SONAR_OBSERVER, '--wait-subscribers', '60'], env=ros.env,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        ros.spin_until(lambda: len(sink.msgs[SONAR_ESTIMATE]) >= RECORD_S or player.poll() is not None, timeout=180)
        ros.spin_until(lambda: all(len(sink.msgs[t]) >= len(recorded[t])
                                   for t in (SONAR_ESTIMATE, SONAR_MODE, SONAR_MODE_COMMAND)), timeout=30)
    finally:
        _, err = player.communicate(timeout=30)
    assert player.returncode == 0, err
    assert observer.k == RECORD_S and observer.tracker.predictions == 0
    for topic in (SONAR_ESTIMATE, SONAR_MODE):
        assert sink.msgs[topic] == recorded[topic], topic  # message equality: every field, exactly
    # the requests after each step (the start request, stamp 0, is latched and comes first or not at all)
    got = [m for m in sink.msgs[SONAR_MODE_COMMAND] if stamp_to_ns(m.header.stamp) > 0]
    assert got == [m for m in recorded[SONAR_MODE_COMMAND] if stamp_to_ns(m.header.stamp) > 0]


# --- any start order ------------------------------------------------------------------------------

@pytest.mark.parametrize('order', [('smart_target', 'sonar_sim', 'sonar_observer'),
                                   ('sonar_observer', 'sonar_sim', 'smart_target')])
def test_the_three_started_by_hand_3_s_apart_step_together(ros, repo, prefix, order):
    """Wall time, three processes through the shims, each started 3 s after the one before: estimates flow."""
    sink = Sink(ros)
    cmd = ['--ros-args', '--params-file', str(repo / 'config/sonar.yaml')]
    procs = []
    try:
        for exe in order:
            if procs:
                ros.spin_for(3.0)  # the gap under test, not a wait for a condition
            procs.append(subprocess.Popen([str(prefix / 'lib/track_nodes' / exe), *cmd], env=ros.env,
                                          stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True))
        assert ros.spin_until(lambda: len(sink.msgs[SONAR_ESTIMATE]) >= 4, timeout=90), \
            f'no estimates: truth {len(sink.msgs[SONAR_TRUTH])}, observer {len(sink.msgs[SONAR_OBSERVER])}'
        truth_keys = {stamp_to_ns(m.header.stamp) for m in sink.msgs[SONAR_TRUTH]}
        assert all(stamp_to_ns(m.header.stamp) in truth_keys for m in sink.msgs[SONAR_ESTIMATE])
    finally:
        for p in procs:
            p.send_signal(2)
        for p in procs:
            _, err = p.communicate(timeout=30)
            assert p.returncode == 0 and 'Traceback' not in err, err


# --- bad parameters ---------------------------------------------------------------------------------

@pytest.mark.parametrize(('node', 'line', 'words'), [
    ('sonar_observer', 'delta: -1.0', ['delta', '-1', 'allowed']),
    ('sonar_observer', 'n_particles: 0', ['n_particles', '0', 'allowed']),
    ('sonar_observer', 'P_D: [5.0, 0.25, -5.0, 0.25]', ['P_D', '-5.0', 'PSD']),
    ('sonar_observer', 'tracker: kalman', ['tracker', 'kalman', 'ss-pf']),
    ('smart_target', 'p_max: 1.5', ['p_max', '1.5', 'allowed']),
    ('sonar_sim', 'legs: [10.0]', ['legs', 'allowed']),
    ('sonar_observer', 'body_frame: map', ['world_frame', 'body_frame', 'map']),
])
def test_bad_parameter_stops_the_shim_with_one_line(tmp_path, prefix, env_factory, node, line, words):
    bad = tmp_path / 'bad.yaml'
    bad.write_text(f'{node}:\n  ros__parameters:\n    {line}\n')
    proc = subprocess.run([str(prefix / 'lib/track_nodes' / node), '--ros-args', '--params-file', str(bad)],
                          capture_output=True, text=True, timeout=60, env=env_factory())
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and 'Traceback' not in proc.stderr, proc.stderr
    assert all(w in lines[0] for w in words), lines[0]


@pytest.mark.parametrize(('value', 'words'), [
    ([1.0, 2.0, 3.0], 'has 3 values'),
    ([5.0, 0.0, 0.0, 0.0, 1.0, 0.25, 0.0, 0.0, 0.0, 0.0, 5.0, 0.0, 0.0, 0.0, 0.0, 0.25], 'symmetric'),
])
def test_bad_p_d_in_process(ros, value, words):
    with pytest.raises(ParameterError, match=words):
        SonarObserverNode(context=ros.context, parameter_overrides=[Parameter('P_D', value=value)])


# --- bring your own sonar -------------------------------------------------------------------------

def test_a_driver_of_your_own_gets_an_estimate_for_every_contact_and_through_a_gap(ros, repo):
    """docs/examples/sonar_driver.py (irregular contacts, a 10 s gap, REP-105 navigation, no truth topic)
    into a sonar_observer with its defaults: an estimate at every contact's stamp, predict-only estimates
    published live during the gap (before the next contact), and a track near the example's target."""
    import importlib.util

    spec = importlib.util.spec_from_file_location('sonar_driver', repo / 'docs/examples/sonar_driver.py')
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    sim = [Parameter('use_sim_time', value=True)]
    observer = ros.add(SonarObserverNode(context=ros.context, parameter_overrides=[
        *sim, Parameter('prior_mean', value=[400.0, -3.0, 300.0, 2.0])]))
    driver = ros.add(example.SonarDriverExample(duration=40.0, context=ros.context, parameter_overrides=sim))
    estimates: list[Odometry] = []
    ros.add(Node('byo_sink', context=ros.context)).create_subscription(
        Odometry, SONAR_ESTIMATE, estimates.append, ESTIMATE_QOS)
    clock = ros.add(Node('byo_clock', context=ros.context)).create_publisher(Clock, CLOCK, CLOCK_QOS)
    assert ros.spin_until(lambda: driver.pub_contact.get_subscription_count() > 0
                          and observer.pub_est.get_subscription_count() > 0, timeout=30)
    start = 1_000 * 10**9
    seq = observer.sequencer
    for i in range(0, 42 * 20):
        now = start + i * 50_000_000
        clock.publish(Clock(clock=Time(nanoseconds=now).to_msg()))
        assert ros.spin_until(lambda now=now: driver.get_clock().now().nanoseconds == now
                              and observer.get_clock().now().nanoseconds == now
                              and seq.updates + len(seq.held) + observer.rejected + observer.dropped
                              == len(driver.sent), timeout=30), f'tick {i}'
    assert ros.spin_until(lambda: len(estimates) >= seq.updates + seq.predictions, timeout=30)
    assert observer.rejected == observer.dropped == 0 and seq.updates == len(driver.sent) > 25
    stamps = [stamp_to_ns(m.header.stamp) for m in estimates]
    assert set(driver.sent) <= set(stamps)  # an estimate at every contact
    t = [(s - driver.t0) * 1e-9 for s in stamps]
    in_gap = [i for i, ti in enumerate(t) if example.GAP[0] + 1 < ti < example.GAP[1] - 1]
    after = next(i for i, ti in enumerate(t) if ti > example.GAP[1] and stamps[i] in driver.sent)
    assert len(in_gap) >= 7 and max(in_gap) < after  # predicted live, one per period, before the next contact
    assert seq.predictions >= 9
    _, x, _ = odometry_to_cv_state(estimates[-1])
    err = np.hypot(*(x[[0, 2]] - example.SonarDriverExample.target(t[-1])))
    print(f'contacts {seq.updates}, predict-only steps {seq.predictions}, final position error {err:.2f} m')
    assert err < 25.0, err

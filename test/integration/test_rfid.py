"""RFID scenario (issue 5): rfid_reader and rfid_guidance in-process and through the launcher.

- In-process on sim time (/clock from the test): the two nodes find the tag, and they replay the
  core-only search ``run_search(world, pf, default_rng(seed), max_steps)`` with the scenario's seed
  exactly (same steps, turns, distance, commands).
- Bad input to the guidance (a NaN dφ, an empty phase stream, an unknown kind): one warning line, the
  filter state unchanged, the step asked again. Bad commands to the reader (an unknown kind, a NaN
  angle, seq 0): refused with one line, nothing performed. A replayed answer (the reader's copy for
  a re-sent command) is no bad input. The guidance re-sends its command until answered; the reader
  answers each seq once.
- Bad parameters stop a node at start with one line.
- Launcher: ``config/rfid.yaml`` recorded; the bag has every topic and the summary says found.
"""

from __future__ import annotations

import importlib.util
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from geometry_msgs.msg import PointStamped, PoseArray, PoseStamped
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.serialization import deserialize_message
from rosbags.rosbag2 import Reader
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import PointCloud2
from tf2_msgs.msg import TFMessage

from track_core.rfid.pf import PFParams
from track_core.rfid.phase import PhaseModel
from track_core.rfid.protocol import CommandKind
from track_core.rfid.search import run_search
from track_core.rfid.world import WorldParams
from track_msgs import msg as tm
from track_msgs_py.clouds import pointcloud2_to_table
from track_msgs_py.qos import CLOCK_QOS, ESTIMATE_QOS, SENSOR_QOS
from track_msgs_py.records.rfid import RfidCommand, RfidStep
from track_msgs_py.stamps import sec_to_stamp
from track_msgs_py.tf import TF, TF_STATIC
from track_msgs_py.topics import (
    CLOCK,
    RFID_COMMAND,
    RFID_FOUND,
    RFID_PARTICLES,
    RFID_PHASE,
    RFID_STEP,
    RFID_TAG_ESTIMATE,
    RFID_USER_POSE,
    RFID_USER_STATUS,
    display_twin,
)
from track_nodes.bag.api import mcap_problem
from track_nodes.bag.check import check_bag
from track_nodes.bag.frames import check_frames
from track_nodes.base import ParameterError
from track_nodes.base.scenario_file import node_params
from track_nodes.rfid.rfid_guidance import RfidGuidanceNode
from track_nodes.rfid.rfid_reader import RfidReaderNode

DISPLAYS = Path(__file__).resolve().parents[2] / 'tools/displays.py'  # a script, not a package module: loaded by path
_spec = importlib.util.spec_from_file_location('displays_tool', DISPLAYS)
_displays = sys.modules.setdefault('displays_tool', importlib.util.module_from_spec(_spec))  # dataclasses look it up
_spec.loader.exec_module(_displays)
undrawn_in_bag = _displays.undrawn_in_bag

TYPES = {RFID_COMMAND: tm.RfidCommand, RFID_STEP: tm.RfidStep, RFID_PHASE: PointCloud2,
         RFID_USER_POSE: PoseStamped, RFID_USER_STATUS: tm.RfidUserStatus, RFID_PARTICLES: PoseArray,
         RFID_TAG_ESTIMATE: PointStamped, RFID_FOUND: tm.RfidFound, TF: TFMessage, TF_STATIC: TFMessage,
         display_twin(RFID_TAG_ESTIMATE): PoseStamped}  # the estimate as Foxglove's 3D panel draws it
MOVE, TURN, DONE = CommandKind.MOVE, CommandKind.TURN, CommandKind.DONE
RECORD_S = 15.0  # node time of the launcher run: seed 4 is found after ~5 s (time_scale 0.25)


def _config(repo: Path) -> dict:
    return yaml.safe_load((repo / 'config/rfid.yaml').read_text())


def _reference(repo: Path):
    """The core-only search with the scenario's parameters and seed."""
    cfg = _config(repo)
    rp, gp = node_params(cfg, 'rfid_reader'), node_params(cfg, 'rfid_guidance')
    assert rp['seed'] == gp['seed']
    phase = PhaseModel.with_wrap(rp['wrap'], carrier_hz=rp['carrier_hz'], s_theta=math.radians(rp['s_theta_deg']))
    world = WorldParams(phase=phase, start_distance=rp['start_distance'], beam_width=math.radians(rp['beam_width_deg']),
                        s_step=rp['s_step'], s_r=rp['s_r'], s_a=math.radians(rp['s_a_deg']),
                        found_radius=rp['found_radius'])
    pf = PFParams(n_particles=gp['n_particles'], s_step=gp['s_step'], s_r=gp['s_r'], s_a=math.radians(gp['s_a_deg']))
    return run_search(world, pf, np.random.default_rng(rp['seed']), max_steps=gp['max_steps'])


def _node(ros, repo, cls, name, **over):
    params = [Parameter('use_sim_time', value=True), *[Parameter(k, value=v) for k, v in over.items()]]
    return ros.add(cls(node_name=name, context=ros.context, parameter_overrides=params,
                       cli_args=['--ros-args', '--params-file', str(repo / 'config/rfid.yaml')]))


def _command(msg: tm.RfidCommand) -> RfidCommand:
    return RfidCommand.from_msg(msg)


def _step(msg: tm.RfidStep) -> RfidStep:
    return RfidStep.from_msg(msg)


class Sink:
    """Collects the /rfid topics in a node of the test's context."""

    def __init__(self, ros) -> None:
        self.node = ros.add(Node('rfid_sink', context=ros.context))
        self.msgs: dict[str, list] = {t: [] for t in TYPES}
        for topic, cls in TYPES.items():
            qos = SENSOR_QOS if topic == RFID_PARTICLES else ESTIMATE_QOS
            self.node.create_subscription(cls, topic, self.msgs[topic].append, qos)


class TestClock:
    """Publishes /clock from the test: t advances by dt per tick, callbacks run in between."""

    __test__ = False

    def __init__(self, ros) -> None:
        self.ros = ros
        self.pub = ros.add(Node('test_clock', context=ros.context)).create_publisher(Clock, CLOCK, CLOCK_QOS)
        self.t = 0.0

    def run_until(self, predicate, dt: float = 0.05, timeout_s: float = 60.0) -> bool:
        """Tick until ``predicate()`` (or ``timeout_s`` of node time)."""
        t_end = self.t + timeout_s
        while not predicate() and self.t < t_end:
            self.t += dt
            self.pub.publish(Clock(clock=sec_to_stamp(self.t)))
            for _ in range(40):
                self.ros.executor.spin_once(timeout_sec=0.001)
                if predicate():
                    break
        return bool(predicate())


# --- the two nodes find the tag -------------------------------------------------------------------

@pytest.fixture
def search_run(ros, repo):
    """Reader and guidance in-process (answers at once: time_scale 0), until the search ends."""
    reader = _node(ros, repo, RfidReaderNode, 'rfid_reader', time_scale=0.0)
    guide = _node(ros, repo, RfidGuidanceNode, 'rfid_guidance')
    sink = Sink(ros)
    clock = TestClock(ros)
    assert ros.spin_until(lambda: guide.pub_cmd.get_subscription_count() >= 2
                          and reader.pub_step.get_subscription_count() >= 2, timeout=10)
    assert clock.run_until(lambda: guide.loop.ended and guide.loop.answered, timeout_s=120), \
        f'search not over: {guide.loop.moves} moves, last command {guide.loop.cmd}'
    assert ros.spin_until(lambda: len(sink.msgs[RFID_STEP]) >= guide.loop.cmd.seq)
    return reader, guide, sink


def test_the_two_nodes_find_the_tag(search_run, repo):
    reader, guide, sink = search_run
    ref = _reference(repo)
    assert ref.success
    assert guide.found and reader.reader.found()
    assert reader.reader.distance_to_tag() <= node_params(_config(repo), 'rfid_reader')['found_radius']
    assert len(sink.msgs[RFID_FOUND]) == 1
    # the node pair replays the core-only search with the same seed, exactly
    r = reader.reader
    assert (r.steps, r.turns, r.repeats) == (ref.steps, ref.turns, ref.repeats)
    assert r.distance == ref.distance_m and r.distance_to_tag() == ref.final_distance_m
    # one answer per command, in order, every seq once; the last command is DONE
    cmds = [_command(m) for m in sink.msgs[RFID_COMMAND]]
    steps = [_step(m) for m in sink.msgs[RFID_STEP]]
    assert [c.seq for c in cmds] == list(range(1, len(cmds) + 1))
    assert [s.seq for s in steps] == list(range(1, len(cmds) + 1))
    assert [c.kind for c in cmds] == [s.kind for s in steps]
    assert cmds[-1].kind is DONE and cmds[-1].reason == 'tag found'
    moves = [s for s in steps if s.kind is MOVE]
    assert len(moves) == ref.steps == guide.loop.moves
    # one phase cloud per MOVE with the stream's reads; particles after each usable MOVE
    assert len(sink.msgs[RFID_PHASE]) == ref.steps
    for cloud, s in zip(sink.msgs[RFID_PHASE], moves, strict=True):
        table = pointcloud2_to_table(cloud)
        assert list(table) == ['x', 'y', 'z', 't', 'phase', 'rssi', 'carrier_mhz'] and len(table['t']) == s.n_reads
        assert np.all((table['phase'] > 0) & (table['phase'] <= math.pi + 1e-6))
        # issue 19: each read where the reader was (map, tag at the origin): within a step of the user's
        # pose before the MOVE (user poses: the start, then one after each command)
        assert cloud.header.frame_id == 'map' and not table['z'].any()
        before = sink.msgs[RFID_USER_POSE][s.seq - 1].pose.position
        assert np.all(np.hypot(table['x'] - before.x, table['y'] - before.y) < 1.0)
    usable = [s for s in moves if s.ok and s.dphi is not None and math.isfinite(s.dphi)]
    assert len(sink.msgs[RFID_PARTICLES]) == len(usable) == guide.guide.pf.n_updates
    assert len(sink.msgs[RFID_PARTICLES][-1].poses) == guide.p.n_particles
    assert sink.msgs[RFID_TAG_ESTIMATE] and all(m.header.frame_id == 'rfid_user' for m in sink.msgs[RFID_TAG_ESTIMATE])
    sides = guide.tag_sides                   # the mirror modes of the last update, both probabilities
    assert sides.left.probability + sides.right.probability == pytest.approx(1.0)
    last_pose = sink.msgs[RFID_USER_POSE][-1].pose.position
    assert math.hypot(last_pose.x, last_pose.y) == pytest.approx(ref.final_distance_m)


# --- bad input, re-sending, one answer per seq -----------------------------------------------------

class FakeReader:
    """The test plays the reader: it records the guidance's commands and publishes step results."""

    def __init__(self, ros) -> None:
        self.node = ros.add(Node('fake_reader', context=ros.context))
        self.pub = self.node.create_publisher(tm.RfidStep, RFID_STEP, ESTIMATE_QOS)
        self.cmds: list[RfidCommand] = []
        self.node.create_subscription(tm.RfidCommand, RFID_COMMAND, lambda m: self.cmds.append(_command(m)),
                                      ESTIMATE_QOS)

    def answer(self, seq: int, kind: CommandKind, wire: dict | None = None, **fields) -> None:
        """A step result; ``wire``: message fields set afterwards (what no record would write)."""
        v = {'dphi': None, 'turn': 0.0, 'n_reads': 150, 'n_outliers': 1, 'ok': True, 'reason': '',
             'found': False, 'duration': 0.5, **fields}
        msg = RfidStep(seq, kind, **v).to_msg(0.0)
        for k, x in (wire or {}).items():
            setattr(msg, k, x)
        self.pub.publish(msg)


def _guidance_with_fake_reader(ros, repo, **over):
    guide = _node(ros, repo, RfidGuidanceNode, 'rfid_guidance', **over)
    fake = FakeReader(ros)
    clock = TestClock(ros)
    assert ros.spin_until(lambda: guide.pub_cmd.get_subscription_count() >= 1, timeout=10)
    assert clock.run_until(lambda: len(fake.cmds) >= 1, timeout_s=5)
    return guide, fake, clock


@pytest.mark.parametrize(('values', 'needle'), [
    ({'dphi': math.nan}, "phase difference is nan"),
    ({'dphi': 1.5, 'wire': {'dphi_known': False}}, "phase difference is nan"),  # on the wire: no dφ
    ({'dphi': 1.5, 'n_reads': 0}, 'empty phase stream'),
    ({'dphi': 1.5, 'wire': {'kind': 9}}, 'malformed step result: rfid step result: kind 9 is not one of'),
    ({'dphi': 1.5, 'wire': {'duration': math.nan}}, 'non-finite duration=nan'),
])
def test_bad_step_result_warns_keeps_the_state_and_repeats(ros, repo, capfd, values, needle):
    guide, fake, clock = _guidance_with_fake_reader(ros, repo)
    assert fake.cmds[0].seq == 1 and fake.cmds[0].kind is MOVE
    fake.answer(1, MOVE, dphi=-4.0)                 # a usable first step: the filter exists
    assert clock.run_until(lambda: len(fake.cmds) >= 2)
    assert fake.cmds[1].kind is TURN
    fake.answer(2, TURN, turn=0.3)
    assert clock.run_until(lambda: len(fake.cmds) >= 3)
    assert fake.cmds[2].kind is MOVE and not fake.cmds[2].repeat
    core = guide.guide
    before = (core.pf.snapshot(), core.pending_turn, core.pf.n_updates)
    capfd.readouterr()
    fake.answer(3, MOVE, **values)
    assert clock.run_until(lambda: len(fake.cmds) >= 4)
    repeat = fake.cmds[3]
    assert (repeat.kind, repeat.seq, repeat.repeat) == (MOVE, 4, True)
    assert needle in repeat.reason
    # filter state exactly as it was (particles, weights, counters, generator), turn sum kept
    after = (core.pf.snapshot(), core.pending_turn, core.pf.n_updates)
    for a, b in zip(before[0][:2], after[0][:2], strict=True):
        np.testing.assert_array_equal(a, b)
    assert before[0][2:] == after[0][2:] and before[1:] == after[1:] == (0.3, 1)
    # one clear warning line
    assert len(guide.warnings) == 1 and needle in guide.warnings[0] and 'unchanged' in guide.warnings[0]
    warn = [ln for ln in capfd.readouterr().err.splitlines() if 'WARN' in ln and 'rfid_guidance' in ln]
    assert len(warn) == 1 and needle in warn[0] and 'repeat' in warn[0], warn
    # the repeated step, answered properly, is used
    fake.answer(4, MOVE, dphi=-4.2)
    assert clock.run_until(lambda: len(fake.cmds) >= 5)
    assert fake.cmds[4].kind is TURN and core.pf.n_updates == 2 and core.pending_turn == 0.0


def test_command_resent_until_answered_and_replayed_answers_ignored(ros, repo):
    guide, fake, clock = _guidance_with_fake_reader(ros, repo, resend_after=0.5)
    assert clock.run_until(lambda: len(fake.cmds) >= 3, timeout_s=5)  # not answered: re-sent, unchanged
    assert fake.cmds[0] == fake.cmds[1] == fake.cmds[2] and guide.loop.resends >= 2
    fake.answer(1, MOVE, dphi=-4.0)
    assert clock.run_until(lambda: fake.cmds[-1].seq == 2)
    n = len(fake.cmds)
    fake.answer(1, MOVE, dphi=-4.0)                  # the reader's copy of an answer already used
    clock.run_until(lambda: False, timeout_s=0.3)
    assert len(fake.cmds) == n and not guide.warnings and guide.loop.stale == 1 and guide.guide.pf.n_updates == 1


def _fake_guidance(ros, reader):
    """The test plays the guidance: ``command(seq, kind, angle, wire)`` publishes one command; ``wire``
    sets message fields afterwards (what no record would write)."""
    pub = ros.add(Node('fake_guidance', context=ros.context)).create_publisher(tm.RfidCommand, RFID_COMMAND,
                                                                               ESTIMATE_QOS)
    assert ros.spin_until(lambda: reader.pub_step.get_subscription_count() >= 1
                          and pub.get_subscription_count() >= 1, timeout=10)

    def command(seq: int, kind: CommandKind = MOVE, angle: float = 0.0, wire: dict | None = None) -> None:
        msg = RfidCommand(seq, kind, angle).to_msg(0.0)
        for k, v in (wire or {}).items():
            setattr(msg, k, v)
        pub.publish(msg)

    return command, pub


def test_reader_answers_each_seq_once(ros, repo):
    reader = _node(ros, repo, RfidReaderNode, 'rfid_reader', time_scale=0.0)
    sink = Sink(ros)
    command, _ = _fake_guidance(ros, reader)
    command(1, MOVE)
    assert ros.spin_until(lambda: len(sink.msgs[RFID_STEP]) == 1)
    command(1, MOVE)                                   # a re-sent copy: same answer, not walked again
    assert ros.spin_until(lambda: len(sink.msgs[RFID_STEP]) == 2)
    assert sink.msgs[RFID_STEP][0] == sink.msgs[RFID_STEP][1] and reader.reader.steps == 1
    command(2, TURN, 0.5)
    assert ros.spin_until(lambda: len(sink.msgs[RFID_STEP]) == 3)
    command(1, MOVE)                                   # older than the last: ignored
    ros.spin_for(0.3)
    assert len(sink.msgs[RFID_STEP]) == 3 and reader.reader.steps == 1 and reader.cache.duplicates == 1
    assert len(sink.msgs[RFID_PHASE]) == 1 and len(sink.msgs[RFID_USER_POSE]) == 3  # start pose + 2 actions


# --- bad parameters ---------------------------------------------------------------------------------

def test_zero_particles_is_a_parameter_error(ros):
    with pytest.raises(ParameterError) as info:
        RfidGuidanceNode(context=ros.context, parameter_overrides=[Parameter('n_particles', value=0)])
    msg = str(info.value)
    assert '\n' not in msg and 'n_particles' in msg and '0' in msg and 'allowed' in msg


@pytest.mark.parametrize(('node', 'line', 'words'), [
    ('rfid_guidance', 'n_particles: 0', ['n_particles', '0', 'allowed']),
    ('rfid_guidance', 'suggestion: median', ['suggestion', 'median', 'auto']),
    ('rfid_reader', 'carrier_hz: 2.4e9', ['carrier_hz', 'allowed']),
    ('rfid_reader', 'wrap: 3pi', ['wrap', '3pi', '2pi']),
])
def test_bad_parameter_stops_the_node_with_one_line(tmp_path, env_factory, node, line, words):
    bad = tmp_path / 'bad.yaml'
    bad.write_text(f'{node}:\n  ros__parameters:\n    {line}\n')
    proc = subprocess.run([sys.executable, '-m', 'track_nodes', node, '--ros-args', '--params-file', str(bad)],
                          capture_output=True, text=True, timeout=60, env=env_factory())
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and 'Traceback' not in proc.stderr, proc.stderr
    assert all(w in lines[0] for w in words), lines[0]


# --- launcher and recording -------------------------------------------------------------------------

def test_launcher_records_the_search_and_the_summary_says_found(tmp_path, env_factory, repo):
    cmd = [sys.executable, '-m', 'track_nodes.launch', str(repo / 'config/rfid.yaml'), '--record', 'rfid',
           '--duration', str(RECORD_S)]
    proc = subprocess.run(cmd, cwd=tmp_path, env=env_factory(), capture_output=True, text=True, timeout=180)
    assert proc.returncode == 0, proc.stderr
    bag = tmp_path / 'bags/rfid'
    counts: dict[str, int] = {}
    found = []
    with Reader(bag) as reader:
        for conn in reader.connections:
            counts[conn.topic] = conn.msgcount
            assert conn.msgtype == f'{TYPES[conn.topic].__module__.split(".")[0]}/msg/{TYPES[conn.topic].__name__}'
        for conn, _, raw in reader.messages():
            if conn.topic == RFID_FOUND:
                found.append(deserialize_message(raw, tm.RfidFound))
    assert set(counts) == set(TYPES), counts
    assert mcap_problem(bag, sum(counts.values())) is None   # Foxglove's mcap reader decodes every message
    assert check_frames(bag, stamps=True) == []  # rfid_user, rfid_pf and the reader's frame are placed in map
    ref = _reference(repo)
    assert len(found) == 1 and counts[RFID_PHASE] == ref.steps
    out = proc.stdout
    assert 'rfid: tag FOUND' in out, out
    assert f'steps {ref.steps}, turns {ref.turns}, distance walked {ref.distance_m:.2f} m' in out, out
    assert f'final distance to the tag {ref.final_distance_m:.3f} m' in out, out
    res = check_bag(bag)  # issue 19: every phase cloud drawable (float32 x, y, z first)
    assert res.ok and res.checked[RFID_PHASE] == ref.steps, res.problems
    assert undrawn_in_bag('rfid', bag) == []  # every 3D entry of the Foxglove layout recorded, of a drawable type


# --- a commercial reader (issue 14) ----------------------------------------------------------------

def test_an_llrp_hopping_reader_with_relock_and_online_noise_finds_the_tag(ros, repo):
    """The real-reader options pass through both nodes: LLRP sign, hopping, lasting steps, re-lock, online noise."""
    reader = _node(ros, repo, RfidReaderNode, 'rfid_reader', time_scale=0.0, convention='llrp', hop_dwell_s=0.2,
                   phase_step_rate=0.5, relock_reads=5, noise='online', s_theta_deg=1.0)
    guide = _node(ros, repo, RfidGuidanceNode, 'rfid_guidance', convention='llrp', weighting='inverse_square')
    sink = Sink(ros)
    clock = TestClock(ros)
    assert ros.spin_until(lambda: guide.pub_cmd.get_subscription_count() >= 2
                          and reader.pub_step.get_subscription_count() >= 2, timeout=10)
    assert clock.run_until(lambda: guide.loop.ended and guide.loop.answered, timeout_s=120)
    assert ros.spin_until(lambda: len(sink.msgs[RFID_STEP]) >= guide.loop.cmd.seq)
    assert guide.found and reader.reader.found()
    channels = set(reader.p.hop_channels_mhz)
    for cloud in sink.msgs[RFID_PHASE]:
        table = pointcloud2_to_table(cloud)
        assert {round(float(f), 3) for f in np.unique(table['carrier_mhz'])} <= channels
    moves = [_step(m) for m in sink.msgs[RFID_STEP] if _step(m).kind is MOVE]
    stds = [m.dphi_std for m in moves if m.ok]
    assert stds and all(math.isfinite(s) and s > 0 for s in stds)       # online noise: the filter gets it
    assert all(m.relocks >= 0 for m in moves)


def test_the_simulators_heavy_tailed_reads_are_node_parameters(ros, repo):
    """noise_dof / noise_burst_s reach the simulated world (Student-t reads in fades), as the experiments use."""
    reader = _node(ros, repo, RfidReaderNode, 'rfid_reader', noise_dof=3.0, noise_burst_s=0.05)
    assert (reader.world.noise_dof, reader.world.noise_burst_s) == (3.0, 0.05)


# --- protocol windows (issue 13, defects 4 and 6) --------------------------------------------------------

def test_reader_refuses_a_seq_far_ahead_and_keeps_answering(ros, repo):
    """Before issue 13 one command with an enormous seq was performed, and every real command after it
    was stale: no step result was ever sent again."""
    reader = _node(ros, repo, RfidReaderNode, 'rfid_reader', time_scale=0.0)
    sink = Sink(ros)
    command, _ = _fake_guidance(ros, reader)
    command(1)
    assert ros.spin_until(lambda: len(sink.msgs[RFID_STEP]) == 1)
    before = (dict(vars(reader.cache)), reader.reader.pose.copy(), reader.reader.steps, reader.reader.t)
    for i, seq in enumerate((2**31 - 1, 10**6, 1 + 17)):
        command(seq)
        assert ros.spin_until(lambda i=i: reader.refusals.total() == i + 1), seq
    after = (dict(vars(reader.cache)), reader.reader.pose, reader.reader.steps, reader.reader.t)
    assert after[0] == before[0] and np.array_equal(after[1], before[1]) and after[2:] == before[2:]
    assert len(sink.msgs[RFID_STEP]) == 1 and list(reader.refusals.counts) == [(RFID_COMMAND, 'seq')]
    command(2, TURN)                                     # the next real command is performed
    assert ros.spin_until(lambda: len(sink.msgs[RFID_STEP]) == 2) and _step(sink.msgs[RFID_STEP][1]).seq == 2


def test_reader_refuses_unknown_kinds_nan_angles_and_seq_0_with_one_line(ros, repo, capfd):
    reader = _node(ros, repo, RfidReaderNode, 'rfid_reader', time_scale=0.0)
    sink = Sink(ros)
    command, _ = _fake_guidance(ros, reader)
    command(1)
    assert ros.spin_until(lambda: len(sink.msgs[RFID_STEP]) == 1)
    before = (reader.reader.pose.copy(), reader.reader.steps, reader.reader.turns, reader.reader.t, reader.cache.seq)
    capfd.readouterr()
    bad = [{'kind': 0}, {'kind': 9}, {'angle': math.nan}, {'angle': math.inf}, {'angle_deg': math.nan}, {'seq': 0}]
    for i, wire in enumerate(bad):
        command(2, TURN, 0.5, wire)
        assert ros.spin_until(lambda i=i: reader.refusals.total() == i + 1), wire
    after = (reader.reader.pose, reader.reader.steps, reader.reader.turns, reader.reader.t, reader.cache.seq)
    assert np.array_equal(after[0], before[0]) and after[1:] == before[1:] and len(sink.msgs[RFID_STEP]) == 1
    assert reader.refusals.counts == {(RFID_COMMAND, 'command'): len(bad)}
    lines = [ln for ln in capfd.readouterr().err.splitlines() if 'WARN' in ln and 'rfid_reader' in ln]
    assert len(lines) == 1 and 'refused: command: rfid command: kind 0 is not one of' in lines[0], lines
    command(2, TURN, 0.5)                                # the same command, well formed, is performed
    assert ros.spin_until(lambda: len(sink.msgs[RFID_STEP]) == 2) and _step(sink.msgs[RFID_STEP][1]).kind is TURN


def test_unsolicited_step_results_are_refused_and_change_nothing(ros, repo):
    """Before issue 13 results ahead of the pending command were used: a flood ended the search."""
    guide, fake, clock = _guidance_with_fake_reader(ros, repo, max_steps=3)
    core = guide.guide
    before = (dict(vars(guide.loop)), core.pending, core.pending_turn, core.failed_in_a_row, core.pf.initialized)
    for i in range(30):
        fake.answer(2 + i, MOVE, dphi=-4.0)
        assert ros.spin_until(lambda i=i: guide.refusals.total() == i + 1, timeout=10)
    after = (dict(vars(guide.loop)), core.pending, core.pending_turn, core.failed_in_a_row, core.pf.initialized)
    assert after == before and guide.loop.moves == 0 and not guide.warnings
    assert guide.refusals.counts == {(RFID_STEP, 'seq'): 30}
    fake.answer(1, MOVE, dphi=-4.0)                      # the real answer is used
    assert clock.run_until(lambda: fake.cmds[-1].seq == 2)
    assert fake.cmds[-1].kind is TURN and guide.loop.moves == 1 and core.pf.n_updates == 1


def test_the_pair_finds_the_tag_through_a_flood_of_unsolicited_results(ros, repo):
    """A third node answers every command with a result far ahead (a forged answer with the right seq is
    indistinguishable; one ahead becomes it once the guidance moves on): the search is the same."""
    reader = _node(ros, repo, RfidReaderNode, 'rfid_reader', time_scale=0.0)
    guide = _node(ros, repo, RfidGuidanceNode, 'rfid_guidance')
    fake = FakeReader(ros)
    fake.node.create_subscription(tm.RfidCommand, RFID_COMMAND, lambda m: fake.answer(
        _command(m).seq + 1000, MOVE, dphi=-4.0, found=True), ESTIMATE_QOS)
    clock = TestClock(ros)
    assert ros.spin_until(lambda: guide.pub_cmd.get_subscription_count() >= 2
                          and reader.pub_step.get_subscription_count() >= 1, timeout=10)
    assert clock.run_until(lambda: guide.loop.ended and guide.loop.answered, timeout_s=120)
    ref = _reference(repo)
    r = reader.reader
    assert guide.found and r.found() and (r.steps, r.turns, r.repeats) == (ref.steps, ref.turns, ref.repeats)
    assert guide.loop.moves == ref.steps and guide.refusals.total() > 0

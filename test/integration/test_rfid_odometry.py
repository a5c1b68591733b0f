"""rfid_guidance with a reader carried by a robot (``motion_source`` odometry), in-process on sim time.

The test plays the reader (step results stamped at the end of their reads, with their duration) and the
robot's driver (nav_msgs/Odometry on /odom). The node's filter after each MOVE must equal the core's fed
the motion the odometry measured (not the commanded step, not the reported turn); a MOVE waits for the
odometry that covers it, and is refused and repeated when none comes within ``odom_wait``; hostile
odometry is refused with its reason and changes nothing.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock

from track_core.rfid.guidance import RfidGuidance
from track_core.rfid.pf import MeasuredMotion
from track_core.rfid.protocol import CommandKind, StepResult
from track_msgs import msg as tm
from track_msgs_py.qos import CLOCK_QOS, ESTIMATE_QOS
from track_msgs_py.records.landmarks import planar_odometry_msg
from track_msgs_py.records.rfid import RfidCommand, RfidStep
from track_msgs_py.stamps import sec_to_stamp
from track_msgs_py.topics import CLOCK, RFID_COMMAND, RFID_STEP, SLAM_ODOM
from track_nodes.base import ParameterError
from track_nodes.rfid.params import pf_config, phase_model
from track_nodes.rfid.rfid_guidance import RfidGuidanceNode

MOVE, TURN = CommandKind.MOVE, CommandKind.TURN
SEED = 3


class Robot:
    """The test as reader and robot driver, and the /clock."""

    def __init__(self, ros) -> None:
        self.ros = ros
        self.node = ros.add(Node('robot', context=ros.context))
        self.pub_step = self.node.create_publisher(tm.RfidStep, RFID_STEP, ESTIMATE_QOS)
        self.pub_odom = self.node.create_publisher(Odometry, SLAM_ODOM, ESTIMATE_QOS)
        self.pub_clock = self.node.create_publisher(Clock, CLOCK, CLOCK_QOS)
        self.cmds: list[RfidCommand] = []
        self.node.create_subscription(tm.RfidCommand, RFID_COMMAND,
                                      lambda m: self.cmds.append(RfidCommand.from_msg(m)), ESTIMATE_QOS)
        self.t = 0.0

    def run_until(self, predicate, timeout_s: float = 30.0, dt: float = 0.05) -> bool:
        """Advance /clock by ``dt`` a tick, spinning between ticks, until ``predicate()`` (or ``timeout_s`` of
        node time)."""
        for _ in range(round(timeout_s / dt)):
            if predicate():
                return True
            self.t += dt
            self.pub_clock.publish(Clock(clock=sec_to_stamp(self.t)))
            self.ros.spin_until(predicate, timeout=dt)
        return bool(predicate())

    def odom(self, t: float, pose, frame: str = 'odom', child: str = 'base_link', **wire) -> None:
        msg = planar_odometry_msg(t, np.asarray(pose, dtype=float), 0.0, 0.0, None, frame, child)
        for path, v in wire.items():           # e.g. position_x=nan: what no driver of ours writes
            obj, name = path.split('_')
            setattr(getattr(msg.pose.pose, {'position': 'position', 'orientation': 'orientation'}[obj]), name, v)
        self.pub_odom.publish(msg)

    def answer(self, seq: int, kind: CommandKind, t_end: float, duration: float = 1.0, **fields) -> None:
        v = {'dphi': None, 'turn': None, 'n_reads': 150, 'n_outliers': 0, 'ok': True, 'reason': '', 'found': False,
             'duration': duration, **fields}
        self.pub_step.publish(RfidStep(seq, kind, **v).to_msg(t_end))


def _start(ros, **over):
    params = [Parameter('use_sim_time', value=True), Parameter('seed', value=SEED),
              Parameter('motion_source', value='odometry'), *[Parameter(k, value=v) for k, v in over.items()]]
    guide = ros.add(RfidGuidanceNode(context=ros.context, parameter_overrides=params))
    robot = Robot(ros)
    assert ros.spin_until(lambda: guide.pub_cmd.get_subscription_count() >= 1
                          and robot.pub_odom.get_subscription_count() >= 1, timeout=20)
    assert robot.run_until(lambda: len(robot.cmds) >= 1)
    assert robot.cmds[0].kind is MOVE
    return guide, robot


def _core(guide) -> RfidGuidance:
    """The core guidance with the node's parameters and its generator (the second of the seed's spawn)."""
    _, pf_ss = np.random.SeedSequence(SEED).spawn(2)
    core = RfidGuidance(pf_config(guide.p), phase_model(guide.p), np.random.default_rng(pf_ss), log_warnings=False,
                        max_repeats=guide.p.max_repeats)
    core.start()
    return core


def _move(seq: int, dphi: float) -> StepResult:
    return StepResult(MOVE, seq, dphi=dphi, n_reads=150)


def test_the_filter_moves_as_the_odometry_measured_not_as_commanded(ros):
    guide, robot = _start(ros)
    robot.odom(10.0, (0.0, 0.0, 0.0))
    robot.answer(1, MOVE, t_end=11.0, dphi=-4.0)         # reads over [10, 11]: odometry up to 10 only
    robot.run_until(lambda: False, timeout_s=0.3)
    assert guide.held is not None and not guide.guide.pf.initialized and len(robot.cmds) == 1   # waiting
    robot.odom(11.0, (0.3, 0.0, 0.0))                     # the robot went 0.3 m of the 0.5 commanded
    assert robot.run_until(lambda: len(robot.cmds) >= 2)
    assert robot.cmds[1].kind is TURN and guide.guide.pf.n_updates == 1 and guide.held is None
    core, commanded = _core(guide), _core(guide)
    core.on_step(_move(1, -4.0), MeasuredMotion(step=(0.3, 0.0, 0.0)))
    commanded.on_step(_move(1, -4.0))
    np.testing.assert_array_equal(guide.guide.pf.particles, core.pf.particles)
    assert not np.array_equal(guide.guide.pf.particles, commanded.pf.particles)
    # the user reports a turn of 0.3 rad; the robot turned 0.5 rad, then drove 0.3 m
    robot.answer(2, TURN, t_end=11.5, turn=0.3)
    assert robot.run_until(lambda: len(robot.cmds) >= 3)
    robot.odom(12.0, (0.3, 0.0, 0.5))
    robot.odom(13.0, (0.3 + 0.3 * math.cos(0.5), 0.3 * math.sin(0.5), 0.5))
    robot.answer(3, MOVE, t_end=13.0, dphi=-3.0)
    assert robot.run_until(lambda: len(robot.cmds) >= 4)
    assert guide.guide.pf.n_updates == 2 and guide.odom_gaps == 0 and not guide.warnings
    core.on_step(StepResult(TURN, 2, turn=0.3, n_reads=150))
    reply = core.on_step(_move(3, -3.0), MeasuredMotion((0.0, 0.0, 0.5), (0.3, 0.0, 0.0)))
    np.testing.assert_allclose(guide.guide.pf.particles, core.pf.particles, rtol=0, atol=1e-12)
    assert robot.cmds[3].angle == pytest.approx(reply.command.angle, abs=1e-12)


def test_a_move_that_odometry_does_not_cover_is_refused_and_repeated(ros):
    guide, robot = _start(ros, odom_wait=0.5)
    robot.odom(10.0, (0.0, 0.0, 0.0))
    robot.answer(1, MOVE, t_end=11.0, dphi=-4.0)         # no odometry at or after 11 s comes
    assert robot.run_until(lambda: len(robot.cmds) >= 2, timeout_s=5)
    again = robot.cmds[1]
    assert again.kind is MOVE and again.repeat and 'odometry does not cover the step' in again.reason
    assert guide.odom_gaps == 1 and not guide.guide.pf.initialized and guide.held is None
    assert any(topic.endswith(RFID_STEP) for topic, _ in guide.refusals.counts)
    # the repeated step, covered, is used
    robot.odom(12.0, (0.5, 0.0, 0.0))
    robot.answer(2, MOVE, t_end=12.0, dphi=-4.0)
    assert robot.run_until(lambda: len(robot.cmds) >= 3)
    assert robot.cmds[2].kind is TURN and guide.guide.pf.n_updates == 1


def test_hostile_odometry_is_refused_with_its_reason_and_changes_nothing(ros):
    guide, robot = _start(ros)
    robot.odom(10.0, (0.0, 0.0, 0.0))
    assert ros.spin_until(lambda: guide.odo.last == 10.0, timeout=10)
    before = (guide.odo.first, guide.odo.last, len(guide.odo.track))
    hostile = [
        ({'position_x': math.nan}, 'pose.pose.position'),
        ({'orientation_w': 0.5}, 'pose.pose.orientation'),              # not a unit quaternion
        ({'frame': 'map'}, 'header.frame_id'),
        ({'child': 'laser'}, 'child_frame_id'),
        ({'t': robot.t + 1e6}, 'header.stamp'),                          # far ahead of the clock
        ({'t': 9.0}, 'header.stamp'),                                    # before the last one
    ]
    for i, (kw, field) in enumerate(hostile):
        robot.odom(kw.pop('t', 11.0 + i), (1.0, 0.0, 0.0), **kw)
        assert ros.spin_until(lambda i=i: guide.refusals.total() == i + 1, timeout=10), field
        assert any(f == field for _, f in guide.refusals.counts), (field, guide.refusals.counts)
        assert (guide.odo.first, guide.odo.last, len(guide.odo.track)) == before
    robot.odom(20.0, (1.0, 0.0, 0.0))                     # the node goes on
    assert ros.spin_until(lambda: guide.odo.last == 20.0, timeout=10)
    assert guide.refusals.total() == len(hostile)


def test_instruction_is_the_default_and_reads_no_odometry(ros):
    guide = ros.add(RfidGuidanceNode(context=ros.context, parameter_overrides=[Parameter('use_sim_time', value=True)]))
    assert guide.p.motion_source == 'instruction' and guide.odo is None and not hasattr(guide, 'sub_odom')


@pytest.mark.parametrize(('over', 'words'), [
    ({'reader_pose': [0.2, 0.0]}, ['reader_pose', '3 finite numbers']),
    ({'base_frame': 'odom'}, ['odom_frame', 'base_frame']),
])
def test_bad_odometry_parameters_stop_the_node_with_one_line(ros, over, words):
    params = [Parameter('motion_source', value='odometry'), *[Parameter(k, value=v) for k, v in over.items()]]
    with pytest.raises(ParameterError) as exc:
        RfidGuidanceNode(context=ros.context, parameter_overrides=params)
    assert all(w in str(exc.value) for w in words) and '\n' not in str(exc.value), str(exc.value)

import math

import numpy as np
import pytest

from track_core.rfid.protocol import Command, CommandKind
from track_core.rfid.world import Rect, SimReader, WorldParams, office_obstacles, read_mask


def test_start_ten_metres_away_reading_the_tag():
    for seed in range(20):
        rd = SimReader(WorldParams(), np.random.default_rng(seed))
        assert rd.distance_to_tag() == pytest.approx(10.0)
        assert read_mask(rd.params, rd.pose[:2], rd.pose[2])


def test_read_mask_beam_back_lobe_and_range():
    p = WorldParams(beam_width=math.radians(68), back_lobe_range=1.0, max_range=12.0)
    xy = np.array([[-5.0, 0.0], [-5.0, 0.0], [-0.5, 0.0], [-13.0, 0.0]])
    head = np.array([math.radians(30), math.radians(40), math.pi, 0.0])
    np.testing.assert_array_equal(read_mask(p, xy, head), [True, False, True, False])


def test_move_produces_a_300_per_second_stream_and_the_dphi():
    p = WorldParams(outlier_prob=0.0)
    rd = SimReader(p, np.random.default_rng(1), start=np.array([-6.0, 0.0, 0.0]))
    out = rd.execute(Command(CommandKind.MOVE, seq=1))
    dur = out.stream.t_end - out.stream.t_start
    assert len(out.stream) == pytest.approx(300 * dur, rel=0.3)
    assert out.result.ok and out.result.n_reads == len(out.stream)
    exact = p.phase.dphi(np.array([-6.0, 0.0]), out.pose[:2])
    assert out.result.dphi == pytest.approx(exact, abs=0.3)
    assert rd.steps == 1 and rd.distance == pytest.approx(np.hypot(*(out.pose[:2] - [-6.0, 0.0])))


def test_turn_reports_the_turn_made():
    rd = SimReader(WorldParams(), np.random.default_rng(2), start=np.array([-6.0, 0.0, 0.0]))
    out = rd.execute(Command(CommandKind.TURN, math.radians(20), seq=1))
    assert out.result.turn == pytest.approx(math.radians(20)) and out.pose[2] == pytest.approx(math.radians(20))
    # the tag would be behind: the user turns to a direction where it is read, and says so
    out = rd.execute(Command(CommandKind.TURN, math.pi, seq=2))
    assert out.result.turn != pytest.approx(math.pi)
    assert read_mask(rd.params, rd.pose[:2], rd.pose[2]) and out.result.n_reads > 0


def test_blocked_way_user_turns_elsewhere_and_never_enters_an_obstacle():
    wall = Rect(-4.0, -0.6, -3.6, 0.6)
    p = WorldParams(obstacles=(wall,))
    rd = SimReader(p, np.random.default_rng(3), start=np.array([-6.0, 0.0, 0.0]))
    out = rd.execute(Command(CommandKind.TURN, 0.0, seq=1))
    assert abs(out.result.turn) > 0.2                 # straight ahead is blocked within the look-ahead
    for k in range(40):
        rd.execute(Command(CommandKind.MOVE, seq=2 * k + 2))
        x, y, h = rd.pose
        rd.execute(Command(CommandKind.TURN, float(math.atan2(-y, -x) - h), seq=2 * k + 3))
        assert not wall.contains(rd.pose[:2])
    assert rd.pose[0] > -3.0                               # got round the wall


def test_segment_entry():
    r = Rect(0.0, 0.0, 1.0, 1.0)
    assert r.segment_entry(np.array([-1.0, 0.5]), np.array([2.0, 0.5])) == pytest.approx(1 / 3)
    assert r.segment_entry(np.array([-1.0, 2.0]), np.array([2.0, 2.0])) is None
    assert r.segment_entry(np.array([0.5, 0.5]), np.array([0.6, 0.6])) == 0.0
    with pytest.raises(ValueError):
        Rect(1.0, 0.0, 0.0, 1.0)


def test_unusable_step_is_undone():
    p = WorldParams(beam_width=math.radians(68), back_lobe_range=0.5)
    rd = SimReader(p, np.random.default_rng(4), start=np.array([-3.0, 0.0, 0.0]))
    rd.pose[2] = math.pi                                   # facing away: no reads at all
    before = rd.pose.copy()
    out = rd.execute(Command(CommandKind.MOVE, seq=1))
    assert not out.result.ok and out.result.n_reads == 0 and 'signal lost' in out.result.reason
    np.testing.assert_array_equal(rd.pose, before)
    assert rd.repeats == 1 and rd.steps == 1 and rd.distance > 0.5


def test_office_obstacles_leave_the_tag_and_start_circle_free():
    obs = office_obstacles()
    assert len(obs) == 12
    assert not any(r.inflate(0.5).contains(np.zeros(2)) for r in obs)
    th = np.linspace(0, 2 * math.pi, 72)
    assert not any(r.contains(10 * np.array([math.cos(t), math.sin(t)])) for r in obs for t in th)


@pytest.mark.parametrize('kw', [{'beam_width': 0.0}, {'start_distance': 20.0}, {'outlier_prob': 1.0},
                                {'read_rate': 0.0}])
def test_bad_world_params(kw):
    with pytest.raises(ValueError):
        WorldParams(**kw)

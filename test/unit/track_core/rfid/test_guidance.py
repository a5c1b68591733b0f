"""The step-by-step API a node pair drives: commands, results, bad input."""

import logging
import math

import numpy as np
import pytest

from track_core.rfid.guidance import RfidGuidance
from track_core.rfid.pf import PFParams
from track_core.rfid.protocol import Command, CommandKind, StepResult, step_result_problem


def guidance(**kw):
    return RfidGuidance(PFParams(n_particles=200), rng=np.random.default_rng(0), **kw)


def move(cmd, dphi=-15.0, n_reads=150, **kw):
    return StepResult(CommandKind.MOVE, cmd.seq, dphi=dphi, n_reads=n_reads, **kw)


def test_sequence_move_turn_move():
    g = guidance()
    c1 = g.start()
    assert c1.kind is CommandKind.MOVE and c1.seq == 1 and not c1.repeat
    r = g.on_step(move(c1))
    assert r.accepted and r.command.kind is CommandKind.TURN and r.update_s is not None
    assert r.command.angle == pytest.approx(g.pf.suggested_turn())
    r2 = g.on_step(StepResult(CommandKind.TURN, r.command.seq, turn=0.7))
    assert r2.accepted and r2.command.kind is CommandKind.MOVE and g.pending_turn == pytest.approx(0.7)
    d, b = g.tag_estimate()
    assert math.isfinite(d) and math.isfinite(b)
    r3 = g.on_step(move(r2.command, dphi=-10.0))
    assert r3.accepted and g.pending_turn == 0.0 and g.pf.n_updates == 2


def test_turns_are_summed_until_the_next_move(monkeypatch):
    g = guidance()
    r = g.on_step(move(g.start()))
    seen = {}
    orig = g.pf.update
    monkeypatch.setattr(g.pf, 'update', lambda dphi, turn: seen.setdefault('turn', turn) or orig(dphi, turn))
    r = g.on_step(StepResult(CommandKind.TURN, r.command.seq, turn=0.5))
    # a second TURN result for a TURN the user asked for is not possible: the guidance wants a MOVE now
    bad = g.on_step(StepResult(CommandKind.TURN, r.command.seq, turn=0.25))
    assert not bad.accepted and 'pending command' in bad.warning
    g.on_step(move(bad.command))
    assert seen['turn'] == pytest.approx(0.5)


@pytest.mark.parametrize('result_kw, needle', [
    ({'dphi': math.nan}, 'nan'),
    ({'n_reads': 0}, 'empty phase stream'),
    ({'ok': False, 'reason': 'signal lost: no reads during the step'}, 'signal lost'),
])
def test_bad_move_result_warns_keeps_state_and_repeats(result_kw, needle, caplog):
    g = guidance()
    r = g.on_step(move(g.start()))
    r = g.on_step(StepResult(CommandKind.TURN, r.command.seq, turn=0.3))
    before = g.pf.snapshot()
    kw = {'dphi': -12.0, 'n_reads': 150, **result_kw}
    with caplog.at_level(logging.WARNING, logger='track_core.rfid.guidance'):
        rep = g.on_step(StepResult(CommandKind.MOVE, r.command.seq, **kw))
    assert not rep.accepted and needle in rep.warning.lower()
    assert rep.command.kind is CommandKind.MOVE and rep.command.repeat and 'repeat the step' in rep.command.reason
    assert rep.command.seq == r.command.seq + 1
    assert any('repeat the step' in m for m in caplog.messages)
    after = g.pf.snapshot()
    np.testing.assert_array_equal(before[0], after[0])
    np.testing.assert_array_equal(before[1], after[1])
    assert before[2:] == after[2:]
    assert g.pending_turn == pytest.approx(0.3)
    ok = g.on_step(move(rep.command))               # the repeated step is used normally
    assert ok.accepted and g.pf.n_updates == 2


def test_nan_turn_is_rejected():
    g = guidance()
    r = g.on_step(move(g.start()))
    rep = g.on_step(StepResult(CommandKind.TURN, r.command.seq, turn=math.nan))
    assert not rep.accepted and rep.command.kind is CommandKind.TURN and rep.command.repeat
    assert rep.command.angle == r.command.angle and g.pending_turn == 0.0


def test_stale_result_is_rejected():
    g = guidance()
    c = g.start()
    rep = g.on_step(StepResult(CommandKind.MOVE, c.seq + 5, dphi=-10.0, n_reads=100))
    assert not rep.accepted and 'does not answer' in rep.warning and not g.pf.initialized


def test_repeated_loss_asks_for_a_half_turn():
    g = guidance(max_repeats=2, log_warnings=False)
    c = g.start()
    r1 = g.on_step(move(c, n_reads=0, dphi=math.nan))
    assert r1.command.kind is CommandKind.MOVE
    r2 = g.on_step(move(r1.command, n_reads=0, dphi=math.nan))
    assert r2.command.kind is CommandKind.TURN and r2.command.angle == pytest.approx(math.pi)
    assert 'turn around' in r2.command.reason and not g.pf.initialized


def test_found_ends_the_search():
    g = guidance()
    r = g.on_step(move(g.start(), found=True))
    assert r.found and r.command.kind is CommandKind.DONE and g.found
    again = g.on_step(move(r.command))
    assert not again.accepted and 'already ended' in again.warning


def test_on_step_before_start():
    with pytest.raises(RuntimeError):
        guidance().on_step(StepResult(CommandKind.MOVE))


def test_problem_rule_directly():
    c = Command(CommandKind.MOVE, seq=3)
    assert step_result_problem(StepResult(CommandKind.MOVE, 3, dphi=1.0, n_reads=10), c) is None
    assert 'TURN' in step_result_problem(StepResult(CommandKind.TURN, 3), c)
    assert str(Command(CommandKind.TURN, math.radians(30), 4, True)) == '#4 TURN +30.0° (repeat)'


def test_user_pose_is_the_weighted_particle_mean_plus_pending_turns():
    from track_core.filters import invert_pose

    g = RfidGuidance(PFParams(n_particles=4), rng=np.random.default_rng(0))
    assert np.all(np.isnan(g.user_pose()))  # before the first update
    g.pf.particles = np.array([[2.0, 0.0, 0.1], [4.0, 0.0, -0.1], [3.0, 2.0, 0.0], [3.0, -2.0, 0.0]])
    g.pf.weights = np.full(4, 0.25)
    g.pending_turn = 0.5
    pose = g.user_pose()
    np.testing.assert_allclose(pose, [3.0, 0.0, 0.5], atol=1e-12)
    # the tag (origin of the filter frame) seen from the user: 3 m behind, turned by -0.5 rad
    tag_in_user = invert_pose(pose)[:2]
    np.testing.assert_allclose(np.hypot(*tag_in_user), 3.0)
    assert math.isclose(math.atan2(tag_in_user[1], tag_in_user[0]), math.pi - 0.5)


def _walk(g, dphis):
    cmd = g.start()
    for d in dphis:
        r = g.on_step(move(cmd, dphi=d))
        r = g.on_step(StepResult(CommandKind.TURN, r.command.seq, turn=0.0))
        cmd = r.command


def test_sign_check_warns_once_naming_the_convention_when_the_first_moves_walk_away(caplog):
    g = guidance()
    with caplog.at_level(logging.WARNING, logger='track_core.rfid.guidance'):
        _walk(g, [12.0, 14.0, -3.0, 15.0, 16.0, 11.0])      # 3 of the first 4 "walking away"
    assert "'convention'" in g.sign_warning and "'paper'" in g.sign_warning and "'llrp'" in g.sign_warning
    assert sum("'convention'" in r.getMessage() for r in caplog.records) == 1
    ok = guidance()
    _walk(ok, [-12.0, 14.0, -3.0, -15.0, 16.0, 11.0])       # 2 of 4: the motion agrees well enough
    assert ok.sign_warning == ''
    off = guidance(sign_check=0)
    _walk(off, [12.0, 14.0, 13.0, 15.0])
    assert off.sign_warning == ''
    with pytest.raises(ValueError):
        guidance(sign_share=0.5)


def test_tag_sides_are_seen_from_the_user_after_the_pending_turns():
    g = RfidGuidance(PFParams(n_particles=4), rng=np.random.default_rng(0))
    g.pf.particles = np.array([[-2.0, -1.0, 0.0], [-2.0, -1.0, 0.0], [-2.0, 1.0, 0.0], [-2.0, -1.0, 0.0]])
    g.pf.weights = np.full(4, 0.25)               # the tag at (2, 1) (p 0.75) or its mirror (2, -1) (p 0.25)
    s = g.tag_sides()
    assert (s.left.x, s.left.y, s.left.probability) == pytest.approx((2.0, 1.0, 0.75))
    g.pending_turn = math.pi / 2                  # the user has since turned left by 90°: the tag is now right
    s = g.tag_sides()
    assert (s.left.x, s.left.y) == pytest.approx((1.0, -2.0)) and (s.right.x, s.right.y) == pytest.approx((-1.0, -2.0))
    assert s.left.probability == pytest.approx(0.75) and s.unknown is g.pf.tag_sides().unknown


@pytest.mark.parametrize(('field', 'value', 'words'), [
    ('dphi', 1e300, 'beyond'), ('dphi', -2e3, 'beyond'), ('dphi_std', 0.0, 'dphi_std'), ('dphi_std', 1e300, 'dphi_std'),
])
def test_a_huge_finite_number_is_refused_and_poisons_nothing(field, value, words):
    """A finite 1e300 is as bad as a NaN: refused with its reason, and every later command is finite."""
    g = guidance()
    c = g.start()
    r = g.on_step(move(c, **{field: value}))
    assert not r.accepted and words in r.warning
    for _ in range(12):  # the search goes on with honest steps
        cmd = r.command
        step = move(cmd, dphi=0.3) if cmd.kind is CommandKind.MOVE else StepResult(CommandKind.TURN, cmd.seq,
                                                                                   turn=cmd.angle)
        r = g.on_step(step)
        assert math.isfinite(r.command.angle)
        if r.command.kind is CommandKind.DONE:
            break


def test_a_turn_beyond_one_turn_is_refused():
    c = Command(CommandKind.TURN, 0.5, seq=4)
    assert 'allowed' in step_result_problem(StepResult(CommandKind.TURN, 4, turn=1e300), c)
    assert step_result_problem(StepResult(CommandKind.TURN, 4, turn=-math.pi), c) is None

"""Protocol windows of the command/response loop (issue 13, defects 4 and 6): an absurd or
unsolicited ``seq`` is refused and leaves the cache / the loop bit-identical."""

from __future__ import annotations

import copy

from track_core.rfid.delivery import SEQ_WINDOW, AnswerCache, CommandLoop, Use, Verdict
from track_core.rfid.protocol import Command, CommandKind


def test_reader_refuses_a_seq_far_ahead_and_keeps_answering():
    cache: AnswerCache = AnswerCache()
    assert cache.on_command(2**31 - 1) is Verdict.AHEAD  # before the first command too
    assert cache.on_command(1) is Verdict.EXECUTE
    cache.store(1, 'a1', 0.0, False)
    assert cache.take_due(0.0) == 'a1'
    before = copy.deepcopy(vars(cache))
    for seq in (2**31 - 1, 2**63, 1 + SEQ_WINDOW + 1):
        assert cache.on_command(seq) is Verdict.AHEAD and 'ahead' in cache.ahead_problem(seq)
    assert vars(cache) == before
    assert cache.on_command(1) is Verdict.REPLAY      # the last one is still served from the cache
    assert cache.on_command(2) is Verdict.EXECUTE     # and the next real command is performed
    assert cache.on_command(1 + SEQ_WINDOW) is Verdict.EXECUTE  # (lost answers: a few ahead is fine)


def test_guidance_refuses_unsolicited_results_and_a_flood_does_not_end_the_search():
    loop = CommandLoop(resend_after=1.0, max_steps=3)
    loop.sent(Command(CommandKind.MOVE, seq=1), 0.0)
    before = copy.deepcopy(vars(loop))
    for k in range(500):
        assert loop.on_result(2 + k, CommandKind.MOVE) is Use.AHEAD
    assert vars(loop) == before and loop.moves == 0
    assert loop.on_result(1, CommandKind.MOVE) is Use.USE and loop.moves == 1  # the real answer counts
    nxt = loop.next_command(Command(CommandKind.TURN, 0.2, seq=2), False, False)
    assert nxt.outcome is None and nxt.command.kind is CommandKind.TURN


def test_after_done_an_unsolicited_result_is_still_refused():
    loop = CommandLoop(resend_after=1.0, max_steps=3)
    loop.sent(Command(CommandKind.DONE, seq=5), 0.0)
    assert loop.on_result(9, CommandKind.DONE) is Use.AHEAD and not loop.answered
    assert loop.on_result(5, CommandKind.DONE) is Use.ENDED and loop.answered

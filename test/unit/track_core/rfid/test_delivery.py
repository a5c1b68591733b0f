"""The command/response loop (track_core.rfid.delivery): unit rules, and identity with the old node path.

``data/loop_cases.json``: 160 random command sequences for the reader and 160 random result
sequences for the guidance, run through the node methods as they were before issue 12 (the
``rfid_reader``/``rfid_guidance`` callbacks at commit 3ac9344, with publishers, clock, simulated
reader and core guidance stubbed); the expected output is what they published and counted. The
drivers below are the new nodes' callbacks with the same stubs: the core must reproduce every case.
"""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import pytest

from track_core.rfid.delivery import AnswerCache, CommandLoop, Tick, Use, Verdict
from track_core.rfid.protocol import Command, CommandKind

CASES = json.loads((Path(__file__).parent / 'data/loop_cases.json').read_text())


def replay_reader(case: dict) -> dict:
    """``RfidReaderNode._on_command`` / ``_tick`` over ``AnswerCache`` (publishing recorded)."""
    cache: AnswerCache = AnswerCache()
    out: list = []
    now, sim_t, scale = 0.0, 0.0, case['time_scale']

    def tick():
        a = cache.take_due(now)
        if a is not None:
            out.extend(a)

    for ev in case['events']:
        if ev[0] == 'tick':
            now += ev[1]
            tick()
            continue
        _, seq, kind, dur, bad = ev
        if bad:
            cache.reject()
            continue
        verdict = cache.on_command(seq)
        if verdict is Verdict.REPLAY:
            out.append(cache.answer[-1])
        elif verdict is Verdict.EXECUTE:
            if cache.seq is None:
                out.extend([['pose', 0], ['status', 0]])
            sim_t += dur
            due = now + scale * dur
            answer = ([['phase']] if kind == 'move' else []) + [['pose', seq], ['status', seq], ['step', seq]]
            cache.store(seq, answer, due, kind == 'done')
            if scale == 0.0:
                tick()
    return {'time_scale': scale, 'events': case['events'], 'out': out, 'duplicates': cache.duplicates,
            'ignored': cache.ignored}


def replay_guidance(case: dict) -> tuple[dict, list[int]]:
    """``RfidGuidanceNode._tick`` / ``_on_step`` over ``CommandLoop``, the core guidance stubbed by the events;
    also the indices of the events refused as unsolicited."""
    loop = CommandLoop(case['resend_after'], case['max_steps'])
    out: list = []
    now, seen = 0.0, False
    g = SimpleNamespace(found=False, turns=0, warnings=0)
    refused: list[int] = []  # events refused as AHEAD (issue 13), outside the saved case

    def send(cmd: Command):
        loop.sent(cmd, now)
        out.append(['cmd', cmd.seq, cmd.kind.value, cmd.reason if cmd.kind is CommandKind.DONE else ''])

    for i, ev in enumerate(case['events']):
        if ev[0] == 'tick':
            now += ev[1]
            seen = ev[2]
            action = loop.tick(now, seen)
            if action is Tick.START:
                send(Command(CommandKind.MOVE, seq=1))
            elif action is Tick.RESEND:
                out.append(out_cmd(loop.cmd))
            continue
        _, seq, kind, found, rkind, core_found, warn, accepted = ev
        if loop.cmd is None:
            continue
        kind = CommandKind(kind)
        use = loop.on_result(seq, kind)
        if use is Use.AHEAD:
            refused.append(i)
        if use is not Use.USE:
            continue
        proposed = Command(CommandKind(rkind), seq=loop.cmd.seq + 1, reason='r')
        if warn:
            g.warnings += 1
        elif kind is CommandKind.TURN:
            g.turns += 1
        if accepted:
            out.append(['estimate', kind is CommandKind.MOVE])
        nxt = loop.next_command(proposed, core_found, found)
        if nxt.outcome == 'found':
            g.found = True
            out.append(['found', loop.cmd.seq if seq is None else seq, loop.moves])
        send(nxt.command)
    return {'resend_after': case['resend_after'], 'max_steps': case['max_steps'], 'events': case['events'],
            'out': out, 'counters': [loop.moves, g.turns, loop.resends, loop.stale, loop.answered, loop.ended,
                                     g.found, g.warnings]}, refused


def out_cmd(cmd: Command) -> list:
    return ['cmd', cmd.seq, cmd.kind.value, cmd.reason if cmd.kind is CommandKind.DONE else '']


@pytest.mark.parametrize('i', range(len(CASES['reader'])))
def test_reader_cache_reproduces_the_old_node(i):
    assert replay_reader(CASES['reader'][i]) == CASES['reader'][i]


@pytest.mark.parametrize('i', range(len(CASES['guidance'])))
def test_guidance_loop_reproduces_the_old_node(i):
    """Identical to the old node, except that results ahead of the pending command (unsolicited, issue 13
    defect 6) are refused: such a case runs as if those results never came."""
    case = CASES['guidance'][i]
    got, refused = replay_guidance(case)
    if not refused:
        assert got == case
        return
    without = dict(case, events=[ev for j, ev in enumerate(case['events']) if j not in set(refused)])
    again, refused_again = replay_guidance(without)
    assert not refused_again and {**got, 'events': without['events']} == again


def test_some_saved_cases_hold_no_unsolicited_result():
    assert sum(not replay_guidance(c)[1] for c in CASES['guidance']) >= 40


def test_the_cases_cover_every_branch():
    outs = [o for c in CASES['reader'] for o in c['out']]
    assert sum(c['duplicates'] for c in CASES['reader']) > 20 and any(o[0] == 'phase' for o in outs)
    g = [o for c in CASES['guidance'] for o in c['out']]
    assert any(o[0] == 'found' for o in g) and any(o[0] == 'cmd' and 'not found' in o[3] for o in g)
    assert sum(c['counters'][2] for c in CASES['guidance']) > 20 and sum(c['counters'][3] for c in CASES['guidance'])


def test_answer_cache_one_answer_per_seq():
    cache: AnswerCache[str] = AnswerCache()
    assert cache.on_command(1) is Verdict.EXECUTE
    cache.store(1, 'a1', due=1.0, done=False)
    assert cache.on_command(1) is Verdict.WAIT and cache.take_due(0.5) is None
    assert cache.take_due(1.0) == 'a1' and cache.take_due(2.0) is None
    assert cache.on_command(1) is Verdict.REPLAY and cache.duplicates == 1
    assert cache.on_command(2) is Verdict.EXECUTE
    cache.store(2, 'done', due=0.0, done=True)
    assert cache.on_command(1) is Verdict.STALE and cache.on_command(3) is Verdict.ENDED and cache.ignored == 2


def test_command_loop_resends_then_ends():
    loop = CommandLoop(resend_after=1.0, max_steps=1)
    assert loop.tick(0.1, reader_seen=False) is Tick.NONE and loop.tick(0.2, reader_seen=True) is Tick.START
    loop.sent(Command(CommandKind.MOVE, seq=1), 0.2)
    assert loop.tick(1.0, True) is Tick.NONE and loop.tick(1.2, True) is Tick.RESEND and loop.resends == 1
    assert loop.on_result(1, CommandKind.MOVE) is Use.USE and loop.moves == 1
    assert loop.on_result(1, CommandKind.MOVE) is Use.STALE and loop.tick(9.0, True) is Tick.NONE
    nxt = loop.next_command(Command(CommandKind.TURN, 0.3, seq=2), core_found=False, result_found=False)
    assert (nxt.outcome, nxt.command.kind, nxt.command.seq) == ('failed', CommandKind.DONE, 2)
    assert nxt.command.reason == 'tag not found after 1 steps'
    loop.sent(nxt.command, 9.0)
    assert loop.ended and loop.on_result(2, CommandKind.DONE) is Use.ENDED and loop.answered


def test_a_found_result_ends_the_search_only_when_it_answers():
    loop = CommandLoop(resend_after=1.0, max_steps=100)
    loop.sent(Command(CommandKind.MOVE, seq=3), 0.0)
    assert loop.on_result(None, CommandKind.MOVE) is Use.USE and loop.moves == 0  # unreadable seq
    assert loop.next_command(Command(CommandKind.MOVE, seq=4), False, result_found=True).outcome is None
    loop.sent(Command(CommandKind.MOVE, seq=4), 0.0)
    loop.on_result(4, CommandKind.MOVE)
    nxt = loop.next_command(Command(CommandKind.TURN, seq=5), False, result_found=True)
    assert nxt.outcome == 'found' and nxt.command == Command(CommandKind.DONE, seq=5, reason='tag found')

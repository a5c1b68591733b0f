"""The command/response loop of the node pair, one side each (pure state machines, no ROS).

``protocol`` says what a command and a result are; this module says how a pair of processes
that may lose, duplicate or reorder messages still performs each command exactly once, in order:

- ``AnswerCache`` (the reader): one answer per ``seq``. A new ``seq`` is executed; a copy of the
  last one gets the cached answer again once that answer is out (nothing is re-executed); an
  older ``seq`` is stale; after DONE nothing more is executed. A ``seq`` more than
  ``SEQ_WINDOW`` ahead of the last one performed (of 0 before the first) is refused (``AHEAD``)
  and changes nothing: the guidance only moves on after an answer, so the next command is the
  last + 1 (a few more when answers were lost), and one absurd ``seq`` must not make every real
  command stale. An answer is held until its
  ``due`` time (the simulated action takes time), then published once.
- ``CommandLoop`` (the guidance): the pending command. The first one goes out once the reader is
  seen; a pending command without an answer is re-sent unchanged every ``resend_after``; a copy
  of an answer already used is stale; a result whose ``seq`` is ahead of the pending command
  answers nothing (``AHEAD``: refused, changes nothing, is not counted); after DONE the loop
  only waits for DONE's answer. It also
  ends the search: DONE when a result reports the tag found, or after ``max_steps`` MOVE results
  (repeated ones included, the count of ``search.run_search``).

Both give the same decisions for the same sequence of inputs and times, so the nodes stay
deterministic for a seed whatever the message timing.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum
from typing import Generic, TypeVar

from track_core.rfid.protocol import Command, CommandKind

A = TypeVar('A')
_EPS = 1e-9  # node-time tolerance of "due" comparisons [s]
SEQ_WINDOW = 16  # how far ahead of the last performed seq a command may be (the saved cases reach 7)


class Verdict(Enum):
    """What the reader does with one command."""

    EXECUTE = 'execute'   # a new seq: perform it
    REPLAY = 'replay'     # a copy of the answered seq: publish the cached answer again
    WAIT = 'wait'         # a copy of the seq being performed: its answer is not out yet
    STALE = 'stale'       # older than the last seq: ignored
    AHEAD = 'ahead'       # more than SEQ_WINDOW after the last seq: refused, nothing changes
    ENDED = 'ended'       # the search is over (DONE was performed): ignored


class AnswerCache(Generic[A]):
    """The reader's side: the last command's answer (any payload ``A``), its due time and the counters."""

    def __init__(self) -> None:
        self.seq: int | None = None      # seq of the last command performed
        self.answer: A | None = None
        self.due = 0.0
        self.published = False
        self.finished = False            # DONE performed
        self.duplicates = 0              # cached answers sent again
        self.ignored = 0                 # stale, after the end, or unreadable

    def on_command(self, seq: int) -> Verdict:
        if self.seq is not None and seq == self.seq:
            if self.published:
                self.duplicates += 1
                return Verdict.REPLAY
            return Verdict.WAIT
        if self.seq is not None and seq < self.seq:
            self.ignored += 1
            return Verdict.STALE
        if seq > (0 if self.seq is None else self.seq) + SEQ_WINDOW:
            return Verdict.AHEAD  # (not counted here: the node reports it; the cache stays as it was)
        if self.finished:
            self.ignored += 1
            return Verdict.ENDED
        return Verdict.EXECUTE

    def ahead_problem(self, seq: int) -> str:
        """The refusal reason of an ``AHEAD`` command."""
        last = 0 if self.seq is None else self.seq
        return f'seq: command #{seq} is more than {SEQ_WINDOW} ahead of the last performed #{last}'

    def reject(self) -> None:
        """An unreadable command (counted with the ignored ones)."""
        self.ignored += 1

    def store(self, seq: int, answer: A, due: float, done: bool) -> None:
        """The answer of the command ``seq`` just performed, to publish at ``due``."""
        self.seq, self.answer, self.due, self.published = seq, answer, due, False
        self.finished = self.finished or done

    def take_due(self, now: float) -> A | None:
        """The answer, once, when ``now`` has reached its due time; else None."""
        if self.seq is None or self.published or now + _EPS < self.due:
            return None
        self.published = True
        return self.answer


class Tick(Enum):
    """What the guidance's timer does."""

    NONE = 'none'
    START = 'start'       # send the first command
    RESEND = 'resend'     # send the pending command again, unchanged


class Use(Enum):
    """What the guidance does with one step result."""

    IGNORE = 'ignore'     # nothing asked yet: not an answer
    STALE = 'stale'       # a copy of a result already used
    AHEAD = 'ahead'       # a seq after the pending command's: answers nothing, refused, nothing changes
    ENDED = 'ended'       # after DONE: only its acknowledgement matters
    USE = 'use'           # hand it to the core guidance


@dataclass(frozen=True)
class Next:
    """The command to send after a result, and how the search ends with it (None: it goes on)."""

    command: Command
    outcome: str | None = None    # 'found' or 'failed'


class CommandLoop:
    """The guidance's side: the pending command, re-sends, stale copies, the end of the search."""

    def __init__(self, resend_after: float, max_steps: int) -> None:
        self.resend_after = float(resend_after)
        self.max_steps = int(max_steps)
        self.cmd: Command | None = None  # the command sent last (pending until answered)
        self.sent_at = 0.0
        self.answered = False
        self.ended = False               # DONE sent
        self.moves = 0                   # MOVE results answering a pending MOVE
        self.resends = 0
        self.stale = 0
        self._answers = False            # the result in hand answers the pending command

    def tick(self, now: float, reader_seen: bool) -> Tick:
        if self.cmd is None:
            return Tick.START if reader_seen else Tick.NONE
        if not self.answered and now - self.sent_at >= self.resend_after - _EPS:
            self.resends += 1
            self.sent_at = now
            return Tick.RESEND
        return Tick.NONE

    def sent(self, cmd: Command, now: float) -> None:
        self.cmd, self.answered, self.sent_at = cmd, False, now
        if cmd.kind is CommandKind.DONE:
            self.ended = True

    def on_result(self, seq: int | None, kind: CommandKind) -> Use:
        """Classify a result with this ``seq`` (None: unreadable) and ``kind``; count MOVEs."""
        cmd = self.cmd
        if cmd is None:
            return Use.IGNORE
        if seq is not None and (seq < cmd.seq or (seq == cmd.seq and self.answered)):
            self.stale += 1
            return Use.STALE
        if seq is not None and seq > cmd.seq:
            return Use.AHEAD  # unsolicited: not counted here (the node reports it), the loop stays as it was
        if self.ended:
            self.answered = self.answered or seq == cmd.seq  # DONE acknowledged: stop re-sending
            return Use.ENDED
        self._answers = self.answered = seq == cmd.seq
        if self._answers and kind is CommandKind.MOVE and cmd.kind is CommandKind.MOVE:
            self.moves += 1
        return Use.USE

    def next_command(self, proposed: Command, core_found: bool, result_found: bool) -> Next:
        """The core's ``proposed`` command, or DONE when the tag is found or the steps are spent."""
        if core_found or (self._answers and result_found):
            cmd = proposed if proposed.kind is CommandKind.DONE else Command(CommandKind.DONE, seq=proposed.seq,
                                                                             reason='tag found')
            return Next(cmd, 'found')
        if self.moves >= self.max_steps and proposed.kind is not CommandKind.DONE:
            return Next(Command(CommandKind.DONE, seq=proposed.seq,
                                reason=f'tag not found after {self.moves} steps'), 'failed')
        return Next(proposed)

"""What the reader (user) and the guidance exchange, one action at a time (Section II).

The guidance sends a ``Command``: TURN by an angle, MOVE one step, or DONE. The reader side
performs it (a real user, or ``world.SimReader``) and answers with a ``StepResult``: the step's
dφ for a MOVE, the turn the user actually made and reports for a TURN, and a ``found`` flag when
the user has reached the tag. Both carry the command's ``seq`` so that a node pair can match a
result to the command it answers; ``repeat`` marks a command re-issued because its result was
unusable.

Angles are in radians, positive counter-clockwise (a left turn).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum


class CommandKind(Enum):
    TURN = 'turn'
    MOVE = 'move'
    DONE = 'done'


@dataclass(frozen=True)
class Command:
    kind: CommandKind
    angle: float = 0.0      # TURN: the suggested turn (rad, + = left)
    seq: int = 0
    repeat: bool = False    # re-issued: the previous result for this action was unusable
    reason: str = ''        # why it is repeated (the warning), or why the search ended

    def __str__(self) -> str:
        s = f'#{self.seq} {self.kind.value.upper()}'
        if self.kind is CommandKind.TURN:
            s += f' {math.degrees(self.angle):+.1f}°'
        return s + (' (repeat)' if self.repeat else '')


@dataclass(frozen=True)
class StepResult:
    """The reader's answer to one command.

    MOVE: ``dphi`` (eq. 6 sign) from the processed phase stream, ``n_reads``/``n_outliers`` of that
    stream, ``ok``/``reason`` from the signal processing (False with a reason when the signal was
    lost or the stream was unusable). TURN: ``turn`` is the turn the user reports having made (the
    suggested one, or another when the way was blocked or the tag was not read that way).
    ``found``: the user is at the tag. ``dphi_std``: the dφ's std from the reader's own noise estimate
    (NaN: unknown, the filter uses its fixed s_θ); ``relocks``: re-locks after lasting phase steps.
    """

    kind: CommandKind
    seq: int = 0
    dphi: float = math.nan
    turn: float = 0.0
    n_reads: int = 0
    n_outliers: int = 0
    ok: bool = True
    reason: str = ''
    found: bool = False
    dphi_std: float = math.nan
    relocks: int = 0


# Bounds of a usable step: a finite 1e300 is as bad as a NaN. |dφ| of a MOVE is at most 4π·s/λ (eq. 6):
# 1000 rad is a step of about 26 m at 865 MHz, beyond any walk; a TURN is within one turn either way;
# a dφ std beyond MAX_DPHI_STD says nothing about dφ (a few wraps).
MAX_DPHI = 1000.0
MAX_TURN = 2.0 * math.pi
MAX_DPHI_STD = 100.0


def step_result_problem(result: StepResult, expected: Command | None = None) -> str | None:
    """Why ``result`` cannot be used, or None when it can (the rule shared by reader and guidance).

    A MOVE needs a finite dφ within ±``MAX_DPHI`` from a non-empty phase stream, and its std (when
    given) positive and at most ``MAX_DPHI_STD``; a TURN needs a finite turn within ±``MAX_TURN``. A
    result for another command than ``expected`` (kind or seq) is rejected too.
    """
    problem = None
    if expected is not None and result.seq != expected.seq:
        problem = f'result #{result.seq} does not answer the pending command #{expected.seq}'
    elif expected is not None and result.kind is not expected.kind:
        problem = (f'result is a {result.kind.value.upper()}, the pending command #{expected.seq} is '
                   f'{expected.kind.value.upper()}')
    elif result.kind is CommandKind.MOVE:
        if not result.ok:
            problem = f'MOVE unusable: {result.reason or "reader reported a failure"}'
        elif result.n_reads <= 0:
            problem = 'MOVE unusable: empty phase stream (no reads during the step)'
        elif not math.isfinite(result.dphi):
            problem = f'MOVE unusable: phase difference is {result.dphi!r}'
        elif abs(result.dphi) > MAX_DPHI:
            problem = f'MOVE unusable: phase difference {result.dphi:.6g} rad is beyond ±{MAX_DPHI:g} rad'
        elif not math.isnan(result.dphi_std) and not 0.0 < result.dphi_std <= MAX_DPHI_STD:
            problem = f'MOVE unusable: dphi_std {result.dphi_std!r} rad is not in (0, {MAX_DPHI_STD:g}]'
    elif result.kind is CommandKind.TURN and not (math.isfinite(result.turn) and abs(result.turn) <= MAX_TURN):
        problem = f'TURN unusable: reported turn is {result.turn!r} (allowed ±2π rad)'
    return problem

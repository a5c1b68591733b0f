"""The guidance side: consumes step results, runs the particle filter, returns the next command.

The sequence (Sections II and VII): the user has found a direction in which the tag is read, and
the guidance asks for one MOVE. Each usable MOVE result runs one filter update (the particles are
created at the first one, ``pf`` module doc) with the turns reported since the previous MOVE
(eq. 19), and the next command is TURN by the suggested angle (eqs. 23–24). Each usable TURN
result adds the reported turn to that sum and the next command is MOVE. A result with ``found``
ends the search (DONE).

A MOVE result with a finite ``dphi_std`` (a reader with online noise, ``signal.PhaseProcessor``)
passes it to the filter update as θ_d's std of eq. 11; NaN (the paper's fixed noise) passes nothing.

Bad input: a result that ``protocol.step_result_problem`` rejects (NaN dφ, an empty phase stream,
a reader failure such as "signal lost", a NaN turn, or a result for another command) leaves the
filter and the turn sum exactly as they were. The reply carries the warning, and its command
repeats the pending one with ``repeat=True`` and a new ``seq``.

Repeated loss (an addition to the paper). A MOVE during which the reads stop has taken the
tag out of the antenna's beam, so the tag is behind the user. Repeating that step from the same
place fails the same way. After ``max_repeats`` consecutive unusable MOVE results the guidance asks
for a half turn instead (TURN by π, reason given), still without touching the filter. That is the
paper's "the user rotates to a different direction and informs the reader", and the turn the user
reports is summed into eq. 19 as usual.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass

import numpy as np

from track_core.filters import circular_mean, wrap_angle
from track_core.rfid.pf import PFParams, RfidParticleFilter
from track_core.rfid.phase import PhaseModel
from track_core.rfid.protocol import Command, CommandKind, StepResult, step_result_problem

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class GuidanceReply:
    command: Command
    accepted: bool                 # the result was used
    warning: str | None = None     # why it was not
    found: bool = False
    update_s: float | None = None  # wall time of the filter update + suggestion, for MOVE results


class RfidGuidance:
    """Step-by-step guidance; one object per search."""

    def __init__(self, params: PFParams | None = None, phase: PhaseModel | None = None,
                 rng: np.random.Generator | None = None, log_warnings: bool = True, max_repeats: int = 2) -> None:
        if max_repeats < 1:
            raise ValueError(f'max_repeats must be >= 1, got {max_repeats}')
        self.log_warnings = log_warnings
        self.max_repeats = max_repeats
        self.failed_in_a_row = 0
        self.pf = RfidParticleFilter(params or PFParams(), phase or PhaseModel(),
                                     rng if rng is not None else np.random.default_rng())
        self.pending_turn = 0.0       # Σ reported turns since the last MOVE (eq. 19)
        self.pending: Command | None = None
        self.found = False
        self._seq = 0
        self.last_update_s: float | None = None

    def _issue(self, kind: CommandKind, angle: float = 0.0, repeat: bool = False, reason: str = '') -> Command:
        self._seq += 1
        self.pending = Command(kind, angle, self._seq, repeat, reason)
        return self.pending

    def start(self) -> Command:
        """The first command: one MOVE in the direction in which the tag is read."""
        return self._issue(CommandKind.MOVE)

    def on_step(self, result: StepResult) -> GuidanceReply:
        if self.pending is None:
            raise RuntimeError('on_step before start()')
        if self.found:
            return GuidanceReply(self.pending, False, 'search already ended: tag found', True)
        problem = step_result_problem(result, self.pending)
        if problem is not None:
            if self.log_warnings:
                log.warning('%s; filter state unchanged, repeat the step', problem)
            p = self.pending
            self.failed_in_a_row += 1
            if p.kind is CommandKind.MOVE and self.failed_in_a_row >= self.max_repeats:
                self.failed_in_a_row = 0
                why = f'{problem}; {self.max_repeats} unusable steps in a row: the tag is behind, turn around'
                cmd = self._issue(CommandKind.TURN, math.pi, True, why)
            else:
                cmd = self._issue(p.kind, p.angle, True, f'{problem}; repeat the step')
            return GuidanceReply(cmd, False, problem)
        self.failed_in_a_row = 0
        upd = None
        if result.kind is CommandKind.MOVE:
            t0 = time.perf_counter()
            # the reader's own dφ std (online noise) replaces s_θ in eq. 11; NaN keeps the paper's fixed s_θ
            kw = {'dphi_std': result.dphi_std} if math.isfinite(result.dphi_std) else {}
            self.pf.update(result.dphi, self.pending_turn, **kw)
            a_sug = self.pf.suggested_turn()
            upd = time.perf_counter() - t0
            self.last_update_s = upd
            self.pending_turn = 0.0
        elif result.kind is CommandKind.TURN:
            self.pending_turn += result.turn
        if result.found:
            self.found = True
            return GuidanceReply(self._issue(CommandKind.DONE, reason='tag found'), True, None, True, upd)
        if result.kind is CommandKind.MOVE:
            return GuidanceReply(self._issue(CommandKind.TURN, a_sug), True, None, False, upd)
        return GuidanceReply(self._issue(CommandKind.MOVE), True)

    def user_pose(self) -> np.ndarray:
        """The user's pose (x, y, facing) in the filter's frame (tag at the origin): weighted mean position and
        circular mean heading of the particles, plus the turns pending since the last MOVE; NaN before the
        first update. The inverse places the filter's frame in the user's (``rfid_guidance`` on /tf)."""
        if not self.pf.initialized:
            return np.full(3, np.nan)
        P, w = self.pf.particles, self.pf.weights
        return np.array([w @ P[:, 0], w @ P[:, 1], float(wrap_angle(circular_mean(P[:, 2], w) + self.pending_turn))])

    def tag_estimate(self) -> tuple[float, float]:
        """(distance, bearing from the facing direction) of the tag; the bearing includes pending turns."""
        d, b = self.pf.tag_estimate()
        return d, float(wrap_angle(b - self.pending_turn)) if math.isfinite(b) else b

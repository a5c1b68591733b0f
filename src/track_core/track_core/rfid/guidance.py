"""The guidance side: consumes step results, runs the particle filter, returns the next command.

The sequence (Sections II and VII): the user has found a direction in which the tag is read, and the
guidance asks for one MOVE. Each usable MOVE result runs one filter update (the particles are
created at the first one, ``pf`` module doc) with the turns reported since the previous MOVE (eq.
19), and the next command is TURN by the suggested angle (eqs. 23–24). Each usable TURN result adds
the reported turn to that sum and the next command is MOVE. A result with ``found`` ends the search
(DONE). A finite ``dphi_std`` (``signal.PhaseProcessor``) is passed to the update as θ_d's std of
eq. 11; NaN (the paper's fixed noise) passes nothing.

Bad input: a result that ``protocol.step_result_problem`` rejects (NaN dφ, an empty phase stream,
"signal lost", a NaN turn, a result for another command) leaves the filter and the turn sum as they
were; the reply carries the warning and repeats the pending command (``repeat=True``, new ``seq``).
After ``max_repeats`` consecutive unusable MOVEs (the tag is behind the user) it asks for a half
turn (TURN by π), the paper's "the user rotates to a different direction".

Sign convention check (``sign_check`` MOVEs, 4 by default; 0 = off): a usable MOVE from beyond the
back lobe should take the user closer (dφ < 0, eq. 6). When at least ``sign_share`` (3/4) of the
first ``sign_check`` usable MOVEs have dφ > 0, ``sign_warning`` names the ``convention`` parameter
(logged once); the filter is not changed. Why and measured: docs/results/rfid.md, "The sign
convention check".
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass

import numpy as np

from track_core.filters import circular_mean, wrap_angle
from track_core.rfid.pf import MeasuredMotion, PFParams, RfidParticleFilter, TagMode, TagSides
from track_core.rfid.phase import PhaseModel
from track_core.rfid.protocol import Command, CommandKind, StepResult, step_result_problem

log = logging.getLogger(__name__)

MAX_REPEATS = 2
"""Unusable MOVE results in a row before the guidance asks for a half turn (the node's default too)."""


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
                 rng: np.random.Generator | None = None, log_warnings: bool = True, max_repeats: int = MAX_REPEATS,
                 sign_check: int = 4, sign_share: float = 0.75) -> None:
        if max_repeats < 1:
            raise ValueError(f'max_repeats must be >= 1, got {max_repeats}')
        if sign_check < 0 or not 0.5 < sign_share <= 1.0:
            raise ValueError(f'sign_check must be >= 0 and sign_share in (0.5, 1], got {sign_check}, {sign_share}')
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
        self.sign_check, self.sign_share = sign_check, sign_share
        self.sign_warning = ''                   # set once when the first MOVEs contradict the motion
        self._away: list[bool] = []              # dφ > 0 (walking away) per usable MOVE, the first sign_check

    def _check_sign(self, dphi: float) -> None:
        """After ``sign_check`` usable MOVEs: mostly "walking away" contradicts the motion (module doc)."""
        self._away.append(dphi > 0.0)
        if len(self._away) != self.sign_check or sum(self._away) < self.sign_share * self.sign_check:
            return
        conv = self.pf.phase.convention
        other = 'llrp' if conv == 'paper' else 'paper'
        self.sign_warning = (f"phase sign contradicts the commanded motion: {sum(self._away)} of the first "
                             f"{self.sign_check} MOVEs towards the read tag measured walking away; check the "
                             f"reader's 'convention' parameter (now {conv!r}; {other!r} fits the motion)")
        if self.log_warnings:
            log.warning('%s', self.sign_warning)

    def _issue(self, kind: CommandKind, angle: float = 0.0, repeat: bool = False, reason: str = '') -> Command:
        self._seq += 1
        self.pending = Command(kind, angle, self._seq, repeat, reason)
        return self.pending

    def start(self) -> Command:
        """The first command: one MOVE in the direction in which the tag is read."""
        return self._issue(CommandKind.MOVE)

    def on_step(self, result: StepResult, motion: MeasuredMotion | None = None) -> GuidanceReply:
        """The next command after ``result``. ``motion``: a usable MOVE's measured motion (a reader carried by
        a robot, ``MeasuredMotion``), used in the update in place of the reported turns and ``s_step``."""
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
            if motion is not None:   # measured (odometry): in place of the turns and s_step
                kw['motion'] = motion
            self.pf.update(result.dphi, self.pending_turn if motion is None else 0.0, **kw)
            a_sug = self.pf.suggested_turn()
            upd = time.perf_counter() - t0
            self.last_update_s = upd
            if len(self._away) < self.sign_check:
                self._check_sign(result.dphi)
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

    def tag_sides(self) -> TagSides:
        """The tag's two mirror modes and their probabilities in the user's frame now (the turns pending since
        the last MOVE applied), ``unknown`` while the walk has not told the sides apart (``pf`` module doc).
        A straight walk cannot tell them apart: a guidance that gave one point would be 2|y| off half the
        time, so it says that the side is unknown and how likely each is (``TagSides.describe``)."""
        sides = self.pf.tag_sides()
        c, s = math.cos(self.pending_turn), math.sin(self.pending_turn)

        def turned(m: TagMode) -> TagMode:   # the user has turned by pending_turn since: R(−turn)·(x, y)
            return TagMode(c * m.x + s * m.y, -s * m.x + c * m.y, m.probability)

        return TagSides(turned(sides.left), turned(sides.right), sides.unknown)

    def tag_estimate(self) -> tuple[float, float]:
        """(distance, bearing from the facing direction) of the tag; the bearing includes pending turns."""
        d, b = self.pf.tag_estimate()
        return d, float(wrap_angle(b - self.pending_turn)) if math.isfinite(b) else b

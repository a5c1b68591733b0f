"""Hybrid CEKF ⇄ particle-filter SLAM (§3), driven one input / one scan at a time.

``HybridSlam.process_input(t, speed, steer)`` and ``process_scan(t, z)`` are what a ``slam``
node calls from its two callbacks; both take time as float seconds and return ``False`` when the
message is refused. Inputs are held (zero-order hold) until the next input or scan.

Switching (§3.1):
- CEKF → PF when the failure detector fires (``association.py``: the uncertainty-vs-separation
  rule). The ambiguity test (more than one candidate in a gate) also triggers only with
  ``trigger_on_ambiguity``: on real data close trunks make it fire at almost every scan.
  The CEKF is flushed (global update), the landmarks that can be in view
  (mean within ``max_range`` + ``n_sigma``·σ_pos + ``candidate_margin`` of the vehicle) are
  re-referenced to two base landmarks (the one nearest the vehicle and the candidate farthest
  from it) and bounded block-diagonally (eq. 11); the SIR filter is helix-initialised from this
  scan (eqs. 12–13) and weighted with the same scan. The map is frozen while in PF mode (pure
  localisation, eq. 2): no map update and no new landmarks.
- PF → CEKF when the PF converges (std < 2·jitter in x, y, φ) or after ``max_pf_scans`` scans
  (documented fallback, event ``pf_timeout``). Restoration of the cross-covariances
  (interpretation): the global pose is g(b₁, b₂, pose_l) with pose_l the PF estimate in the
  base frame, treated as independent of the map; so P_vv = G_b P_bb G_bᵀ + G_l P_pf G_lᵀ and
  P_vm = G_b P_b,m (the vehicle inherits its correlation with the map through the base
  landmarks). The converged scan is then used for a normal CEKF update and the detector is
  muted for ``cooldown_scans`` scans so that the loop-closing update can shrink the map errors.

Bad input: an observation with a non-finite value, a range ≤ 0 or a bearing outside
``bearing_limits`` (the data set's [0, π]) is dropped with a throttled warning; a time stamp
earlier than the last processed one is refused without touching the state.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np

from track_core.filters import wrap_angle
from track_core.slam.cekf import CekfSlam, SlamParams
from track_core.slam.models import VehicleParams
from track_core.slam.pf import (
    ParticleLocaliser,
    PFParams,
    decorrelate_blocks,
    rereference,
    to_global,
)

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class HybridParams:
    enabled: bool = True               # False: plain (C)EKF with nearest neighbour, never switches
    trigger_on_ambiguity: bool = False  # also switch on the ambiguity test (> 1 candidate in the gate)
    max_pf_scans: int = 20
    cooldown_scans: int = 5
    candidate_margin: float = 5.0      # [m]
    bearing_limits: tuple[float, float] = (0.0, np.pi)
    warn_period: float = 5.0           # [s] of data time between repeated warnings

    def __post_init__(self) -> None:
        if self.max_pf_scans < 1:
            raise ValueError(f'max_pf_scans = {self.max_pf_scans}: must be >= 1')
        if self.cooldown_scans < 0:
            raise ValueError(f'cooldown_scans = {self.cooldown_scans}: must be >= 0')
        if not self.bearing_limits[0] < self.bearing_limits[1]:
            raise ValueError(f'bearing_limits = {self.bearing_limits}: need low < high')


@dataclass
class Event:
    t: float
    kind: str        # 'to_pf', 'to_cekf', 'pf_timeout'
    scans: int = 0   # scans spent in PF mode (for 'to_cekf'/'pf_timeout')


@dataclass
class _PFContext:
    pf: ParticleLocaliser
    base: np.ndarray        # global state indices of [b1x, b1y, b2x, b2y]
    t0: float
    prior_cov: np.ndarray
    init_particles: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))


class HybridSlam:
    """CEKF SLAM that hands over to SIR localisation when association cannot be trusted."""

    def __init__(self, pose0: np.ndarray, P0: np.ndarray, rng: np.random.Generator,
                 slam: SlamParams | None = None, pf: PFParams | None = None,
                 hybrid: HybridParams | None = None, *, compressed: bool = True,
                 vehicle: VehicleParams | None = None, t0: float | None = None) -> None:
        vehicle = vehicle or VehicleParams()
        self.cekf = CekfSlam(pose0, P0, slam, compressed=compressed, vehicle=vehicle)
        self.pf_params = pf or PFParams()
        self.params = hybrid or HybridParams()
        self.vehicle = vehicle
        self.rng = rng
        self.t = t0
        self.u = np.zeros(2)
        self.mode = 'CEKF'
        self.events: list[Event] = []
        self.ctx: _PFContext | None = None
        self.cooldown = 0
        self.n_scans = 0
        self.n_dropped = 0
        self._last_warn = -np.inf

    # ------------------------------------------------------------------ time and input
    def _advance(self, t: float) -> bool:
        if not np.isfinite(t):
            self._warn(t, f'non-finite time stamp {t}: refused')
            return False
        if self.t is None:
            self.t = t
            return True
        if t < self.t:
            self._warn(t, f'time stamp {t:.3f} s earlier than {self.t:.3f} s: refused')
            return False
        dt = t - self.t
        if dt > 0:
            if self.mode == 'CEKF':
                self.cekf.predict(self.u, dt)
            else:
                self.ctx.pf.predict(self.u, dt)
        self.t = t
        return True

    def _warn(self, t: float, msg: str) -> None:
        if not np.isfinite(t) or t - self._last_warn >= self.params.warn_period or t < self._last_warn:
            log.warning(msg)
            if np.isfinite(t):
                self._last_warn = t

    def process_input(self, t: float, speed: float, steer: float) -> bool:
        """Encoder speed [m/s] and steering [rad] valid from ``t`` on (zero-order hold)."""
        if not (np.isfinite(speed) and np.isfinite(steer)):
            self._warn(self.t if self.t is not None else 0.0, f'non-finite input ({speed}, {steer}): dropped')
            return False
        if not self._advance(t):
            return False
        self.u = np.array([speed, steer], dtype=float)
        return True

    def valid_observations(self, z: np.ndarray) -> np.ndarray:
        """Mask of usable rows of z (n, 2): finite, range > 0, bearing inside ``bearing_limits``."""
        lo, hi = self.params.bearing_limits
        return np.all(np.isfinite(z), axis=1) & (z[:, 0] > 0) & (z[:, 1] >= lo) & (z[:, 1] <= hi)

    def process_scan(self, t: float, z: np.ndarray) -> bool:
        """One scan of (range [m], bearing [rad], eq. 5 convention) observations at time ``t``."""
        z = np.asarray(z, dtype=float).reshape(-1, 2)
        if not self._advance(t):
            return False
        ok = self.valid_observations(z)
        if not np.all(ok):
            self.n_dropped += int(np.sum(~ok))
            self._warn(t, f'{int(np.sum(~ok))} invalid observation(s) dropped at t = {t:.3f} s')
            z = z[ok]
        self.n_scans += 1
        if self.mode == 'CEKF':
            self._cekf_scan(t, z)
        else:
            self._pf_scan(t, z)
        return True

    # ------------------------------------------------------------------ modes
    def _cekf_scan(self, t: float, z: np.ndarray) -> None:
        assoc, _ = self.cekf.associate(z)
        fired = assoc.risk or (self.params.trigger_on_ambiguity and assoc.ambiguous)
        trigger = self.params.enabled and self.cooldown == 0 and fired and z.shape[0] > 0
        self.cooldown = max(0, self.cooldown - 1)
        if trigger and self._enter_pf(t, z):
            return
        self.cekf.update(z, assoc=assoc if not (self.cekf.compressed and self._will_exit()) else None)

    def _will_exit(self) -> bool:
        c = self.cekf
        return bool(np.linalg.norm(c.xa[:2] - c.center) > c.params.local_exit)

    def _enter_pf(self, t: float, z: np.ndarray) -> bool:
        x, P = self.cekf.mean_cov()
        lm = x[3:].reshape(-1, 2)
        sp = self.cekf.params
        sig = float(np.sqrt(np.max(np.linalg.eigvalsh(P[:2, :2]))))
        dist = np.linalg.norm(lm - x[:2], axis=1)
        cand = np.flatnonzero(dist <= sp.max_range + sp.n_sigma * sig + self.params.candidate_margin)
        if cand.size < 2:
            return False
        b1 = int(np.argmin(dist[cand]))
        b2 = int(np.argmax(np.linalg.norm(lm[cand] - lm[cand[b1]], axis=1)))
        if b1 == b2:
            return False
        idx = np.concatenate([np.arange(3), (3 + 2 * cand[:, None] + np.arange(2)).ravel()])
        pose_l, lm_l, P_l, _ = rereference(x[:3], lm[cand], P[np.ix_(idx, idx)], (b1, b2))
        blocks = decorrelate_blocks(P_l[3:, 3:]) + 1e-6 * np.eye(2)
        pf = ParticleLocaliser(lm_l, blocks, self.pf_params, self.vehicle, self.rng)
        prior_cov = P_l[:3, :3]
        pf.initialise(z, pose_l, prior_cov)
        base = np.concatenate([3 + 2 * cand[b1] + np.arange(2), 3 + 2 * cand[b2] + np.arange(2)])
        self.ctx = _PFContext(pf, base, t, prior_cov, pf.particles.copy())
        self.mode = 'PF'
        self.events.append(Event(t, 'to_pf'))
        log.info('t = %.2f s: association ambiguous, switching to PF localisation (%d landmarks)', t, cand.size)
        self._pf_scan(t, z)
        return True

    def _pf_scan(self, t: float, z: np.ndarray) -> None:
        ctx = self.ctx
        converged = ctx.pf.update(z)
        if converged or ctx.pf.n_scans >= self.params.max_pf_scans:
            mean, cov = ctx.pf._last
            x = self.cekf.x
            pose, Gb, Gl = to_global(mean, x[ctx.base[:2]], x[ctx.base[2:]])
            P = self.cekf.P
            Pvv = Gb @ P[np.ix_(ctx.base, ctx.base)] @ Gb.T + Gl @ cov @ Gl.T
            Pvm = Gb @ P[ctx.base, 3:]
            self.cekf.set_vehicle(pose, Pvv, Pvm)
            self.events.append(Event(t, 'to_cekf' if converged else 'pf_timeout', ctx.pf.n_scans))
            self.mode = 'CEKF'
            self.last_pf = ctx
            self.ctx = None
            self.cooldown = self.params.cooldown_scans
            self.cekf.update(z)

    # ------------------------------------------------------------------ outputs
    @property
    def pose(self) -> np.ndarray:
        if self.mode == 'CEKF':
            return self.cekf.pose
        return self._pf_global(self.ctx.pf.estimate()[0][None])[0]

    @property
    def pose_cov(self) -> np.ndarray:
        if self.mode == 'CEKF':
            return self.cekf.pose_cov
        mean, cov = self.ctx.pf.estimate()
        x = self.cekf.x
        _, _, Gl = to_global(mean, x[self.ctx.base[:2]], x[self.ctx.base[2:]])
        return Gl @ cov @ Gl.T

    def _pf_global(self, p: np.ndarray, ctx: _PFContext | None = None) -> np.ndarray:
        ctx = ctx or self.ctx
        x = self.cekf.x
        b1, b2 = x[ctx.base[:2]], x[ctx.base[2:]]
        d = b2 - b1
        g = float(np.arctan2(d[1], d[0]))
        c, s = np.cos(g), np.sin(g)
        out = np.empty_like(p)
        out[:, 0] = b1[0] + c * p[:, 0] - s * p[:, 1]
        out[:, 1] = b1[1] + s * p[:, 0] + c * p[:, 1]
        out[:, 2] = wrap_angle(p[:, 2] + g)
        return out

    def particles(self) -> np.ndarray:
        """The particle cloud in the global frame (empty outside PF mode)."""
        if self.ctx is None:
            return np.zeros((0, 3))
        return self._pf_global(self.ctx.pf.particles)

    def landmarks(self) -> np.ndarray:
        return self.cekf.landmarks()

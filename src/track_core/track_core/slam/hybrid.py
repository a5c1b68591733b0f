"""Hybrid CEKF ⇄ particle-filter SLAM (§3), driven one input / one scan at a time.

``HybridSlam.process_input(t, speed, steer)`` and ``process_scan(t, z)`` are what a ``slam`` node
calls from its two callbacks; both take time as float seconds and return ``False`` when the message
is refused. Inputs are held (zero-order hold) until the next input or scan.

Switching (§3.1):
- CEKF → PF when the failure detector fires (``association.py``; the ambiguity test only with
  ``trigger_on_ambiguity``). The CEKF is flushed, the landmarks that can be in view (within
  ``max_range`` + ``n_sigma``·σ_pos + ``candidate_margin``) are re-referenced to two base landmarks
  and bounded block-diagonally (eq. 11); the SIR filter is helix-initialised from this scan (eqs.
  12–13) and weighted with it. The map is frozen in PF mode (pure localisation, eq. 2).
- Every scan is used by the filter that runs (the firing scan starts the PF whatever its size);
  ``n_cekf_scans``/``n_pf_scans`` count them (a hand-over scan counts for both).
- PF → CEKF when the PF converges (std < 2·jitter in x, y, φ) or after ``max_pf_scans`` (event
  ``pf_timeout``); meanwhile the CEKF dead-reckons. ``restore='update'`` (default): the PF pose in
  the base frame is fused as an observation z = T(x_v; b₁, b₂) (eq. 10) with the PF's covariance, an
  iterated EKF update (``CekfSlam.fuse``, 3 Gauss–Newton steps); ``'replace'``: P_vv = G_b P_bb G_bᵀ
  + G_l P_pf G_lᵀ, P_vm = G_b P_b,m. Then a normal CEKF update, and the detector is muted for
  ``cooldown_scans``.

Outputs: ``pose``/``pose_cov``, ``particles()`` (PF mode), ``last_particles`` (the last PF step's
cloud) and ``map_estimate()`` (exact means and 2×2 covariances, the filter untouched). Bad input: an
observation non-finite, range ≤ 0 or bearing outside ``bearing_limits`` is dropped
(``valid_observations``); a non-finite or earlier input or stamp is refused (``False``) before any
prediction; equal stamps are accepted. Reasons, measured: docs/results/slam.md.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

import numpy as np

from track_core.slam.cekf import CekfSlam, SlamParams
from track_core.slam.models import InputModel, VehicleParams
from track_core.slam.pf import (
    ParticleLocaliser,
    PFParams,
    base_frame_pose,
    decorrelate_blocks,
    from_base_frame,
    rereference,
    to_global,
)

log = logging.getLogger(__name__)


def valid_observations(z: np.ndarray, bearing_limits: tuple[float, float] = (0.0, np.pi)) -> np.ndarray:
    """Mask of the usable rows of a scan z (n, 2) = (range [m], bearing [rad], eq. 5 convention).

    A row is usable when both values are finite, the range is > 0 and the bearing lies in
    ``bearing_limits`` (closed interval; the data set's laser covers [0, π]). This is the core's
    bad-input rule; ``HybridSlam.process_scan`` applies it (dropping the rest with a throttled
    warning) and a node may call it to count or report dropped rows before calling the core.
    """
    z = np.asarray(z, dtype=float).reshape(-1, 2)
    lo, hi = bearing_limits
    with np.errstate(invalid='ignore'):
        return np.isfinite(z).all(axis=1) & (z[:, 0] > 0) & (z[:, 1] >= lo) & (z[:, 1] <= hi)


def filter_observations(z: np.ndarray, bearing_limits: tuple[float, float] = (0.0, np.pi)) -> tuple[np.ndarray, int]:
    """(usable rows of z, number dropped) by ``valid_observations``."""
    z = np.asarray(z, dtype=float).reshape(-1, 2)
    ok = valid_observations(z, bearing_limits)
    return z[ok], int(z.shape[0] - ok.sum())


@dataclass(frozen=True)
class HybridParams:
    enabled: bool = True               # False: plain (C)EKF with nearest neighbour, never switches
    trigger_on_ambiguity: bool = False  # also switch on the ambiguity test (> 1 candidate in the gate)
    max_pf_scans: int = 20
    cooldown_scans: int = 5
    candidate_margin: float = 5.0      # [m]
    restore: str = 'update'            # PF → CEKF hand-over: 'update' (fuse) or 'replace' (see docstring)
    bearing_limits: tuple[float, float] = (0.0, np.pi)
    warn_period: float = 5.0           # [s] of data time between repeated warnings

    def __post_init__(self) -> None:
        if self.max_pf_scans < 1:
            raise ValueError(f'max_pf_scans = {self.max_pf_scans}: must be >= 1')
        if self.restore not in ('update', 'replace'):
            raise ValueError(f"restore = {self.restore!r}: must be 'update' or 'replace'")
        if self.cooldown_scans < 0:
            raise ValueError(f'cooldown_scans = {self.cooldown_scans}: must be >= 0')
        if not self.bearing_limits[0] < self.bearing_limits[1]:
            raise ValueError(f'bearing_limits = {self.bearing_limits}: need low < high')


@dataclass
class Event:
    t: float
    kind: str        # 'to_pf', 'to_cekf', 'pf_timeout'
    scans: int = 0   # scans spent in PF mode (for 'to_cekf'/'pf_timeout')


@dataclass(frozen=True)
class PFStep:
    """The particle cloud after one PF scan (``HybridSlam.last_particles``)."""

    t: float                # stamp of the scan [s]
    scan: int               # ``HybridSlam.n_scans`` after that scan (equal to it: the PF ran on the latest scan)
    particles: np.ndarray   # (N, 3) global (x, y, φ) after resampling, read-only


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
                 vehicle: InputModel | None = None, t0: float | None = None) -> None:
        vehicle = vehicle or VehicleParams()
        self.cekf = CekfSlam(pose0, P0, slam, compressed=compressed, vehicle=vehicle)
        self.pf_params = pf or PFParams()
        self.params = hybrid or HybridParams()
        self.vehicle = vehicle
        self.rng = rng
        self.t = t0
        self.u = np.zeros(2)
        self.Su: np.ndarray | None = None   # the held input's 2×2 covariance (None: the parameters' σ)
        self.mode = 'CEKF'
        self.events: list[Event] = []
        self.ctx: _PFContext | None = None
        self.cooldown = 0
        self.n_scans = 0
        self.n_dropped = 0
        self.n_cekf_scans = 0   # scans used by a CEKF update (the hand-over scan included)
        self.n_pf_scans = 0     # scans used by the PF (weighting, and the helix of the one that starts it)
        self._last_warn = -np.inf
        self._pf_step: PFStep | None = None

    # ------------------------------------------------------------------ time and input
    def _advance(self, t: float) -> bool:
        t = float(t)
        if not math.isfinite(t):
            self._warn(self.t if self.t is not None else 0.0, f'non-finite time stamp {t}: refused')
            return False
        if self.t is None:
            self.t = t
            return True
        if t < self.t:
            self._warn(t, f'time stamp {t:.3f} s earlier than {self.t:.3f} s: refused')
            return False
        dt = t - self.t
        if dt > 0:
            if self.mode == 'PF':
                self.ctx.pf.predict(self.u, dt, self.Su)
            if self.mode == 'CEKF' or self.params.restore == 'update':
                self.cekf.predict(self.u, dt, self.Su)   # in PF mode: dead reckoning, the prior of the hand-over
        self.t = t
        return True

    def _warn(self, t: float, msg: str) -> None:
        if not np.isfinite(t) or t - self._last_warn >= self.params.warn_period or t < self._last_warn:
            log.warning(msg)
            if np.isfinite(t):
                self._last_warn = t

    def process_input(self, t: float, speed: float, steer: float, cov: np.ndarray | None = None) -> bool:
        """The input model's two inputs, valid from ``t`` on (zero-order hold): encoder speed [m/s] and
        steering [rad] (ACFR), or speed v [m/s] and yaw rate ω [rad/s] (unicycle, ``models``).

        ``cov``: their 2×2 covariance for this hold (an odometry twist covariance); ``None`` uses the
        parameters' σ (``SlamParams``/``PFParams`` ``sigma_v``, ``sigma_steer``). Returns ``False``
        (state untouched, throttled warning) for a non-finite value, a covariance that is not a
        finite symmetric PSD 2×2, or a time stamp earlier than the last processed one.
        """
        speed, steer = float(speed), float(steer)
        if not (math.isfinite(speed) and math.isfinite(steer)):
            self._warn(self.t if self.t is not None else 0.0, f'non-finite input ({speed}, {steer}): dropped')
            return False
        if cov is not None:
            cov = np.asarray(cov, dtype=float)
            if (cov.shape != (2, 2) or not np.all(np.isfinite(cov))
                    or abs(cov[0, 1] - cov[1, 0]) > 1e-9 * (abs(cov[0, 1]) + abs(cov[1, 0]) + 1e-300)
                    or cov[0, 0] < 0 or cov[1, 1] < 0 or cov[0, 0] * cov[1, 1] < cov[0, 1] * cov[1, 0] * (1 - 1e-9)):
                self._warn(self.t if self.t is not None else 0.0, 'input covariance not a finite PSD 2x2: dropped')
                return False
            cov = 0.5 * (cov + cov.T)
        if not self._advance(t):
            return False
        self.u = np.array([speed, steer])
        self.Su = None if cov is None else cov.copy()
        return True

    def valid_observations(self, z: np.ndarray) -> np.ndarray:
        """Mask of usable rows of z (n, 2): see the module function ``valid_observations``."""
        return valid_observations(z, self.params.bearing_limits)

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
        assoc, pred = self.cekf.associate(z)
        fired = assoc.risk or (self.params.trigger_on_ambiguity and assoc.ambiguous)
        trigger = self.params.enabled and self.cooldown == 0 and fired and z.shape[0] > 0
        self.cooldown = max(0, self.cooldown - 1)
        if trigger and self._enter_pf(t, z):
            return
        self.n_cekf_scans += 1
        self.cekf.update(z, assoc=assoc, pred=pred)   # re-associates itself if it leaves the local area

    def _will_exit(self) -> bool:
        return self.cekf.needs_global_update()

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
        self.n_pf_scans += 1
        converged = ctx.pf.update(z)
        cloud = self._pf_global(ctx.pf.particles, ctx)   # the PF's frame: base landmarks as frozen for the episode
        cloud.setflags(write=False)
        self._pf_step = PFStep(float(t), self.n_scans, cloud)
        if converged or ctx.pf.n_scans >= self.params.max_pf_scans:
            mean, cov = ctx.pf._last
            if self.params.restore == 'update':
                cols = np.concatenate([np.arange(3), ctx.base])

                def h(xs):
                    zl, Jv, Jb = base_frame_pose(xs[:3], xs[3:5], xs[5:7])
                    return zl, np.hstack([Jv, Jb])

                self.cekf.fuse(h, cols, mean, cov + 1e-9 * np.eye(3), angle_rows=(2,))
            else:
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
            self.n_cekf_scans += 1
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
        return from_base_frame(p, x[ctx.base[:2]], x[ctx.base[2:]])

    def particles(self) -> np.ndarray:
        """The particle cloud in the global frame (empty outside PF mode)."""
        if self.ctx is None:
            return np.zeros((0, 3))
        return self._pf_global(self.ctx.pf.particles)

    @property
    def last_particles(self) -> PFStep | None:
        """The cloud of the most recent PF step (None before the first one), also after the hand-over.

        ``particles()`` is empty once the PF has converged, so an episode that starts and converges on
        the same scan would never be visible; this keeps the resampled cloud of the last PF scan, its
        stamp and scan count (``step.scan == n_scans``: the PF ran on the latest scan). The cloud is in
        the global frame of the base landmarks as the PF used them (the map is frozen during the
        episode), i.e. before the hand-over update moves them; it equals ``particles()`` after every
        PF scan but the last. Read-only: nothing the caller does reaches the filter.
        """
        return self._pf_step

    def landmarks(self) -> np.ndarray:
        """Landmark means (L, 2); passive ones as of the last CEKF global update (cheap)."""
        return self.cekf.landmarks()

    def map_estimate(self) -> tuple[np.ndarray, np.ndarray]:
        """Exact landmark means (L, 2) and covariances (L, 2, 2), filter untouched (``CekfSlam.map_estimate``)."""
        return self.cekf.map_estimate()

"""The particle filter of Sections IV–V, vectorised over particles.

State (eq. 18): each particle pᵢ = (xᵢ, yᵢ, aᵢ), the user's position and facing direction in a frame
with the tag at the origin O(0, 0). Initialisation (§IV.B) at the start of the first MOVE, in the
bottom-left quadrant (the frame's rotation is a free gauge): polar angle uniform in [π, 3π/2],
distance uniform in ``init_range``, heading = bearing to tag + ψ, ψ uniform in ±``beam_width``/2.

``update`` for one MOVE:
1. Jitter (eq. 21): x, y += N(0, (2 s_r)²) on the previous posterior (not at the first update).
2. Motion (eqs. 19–20): heading a + a_u + n_a (a_u the turns since the last move, n_a ~ N(0, s_a));
   step s_step + r, r ~ N(0, s_r).
3. Weights (eqs. 22, 15): m = −(4π/λ)(|p_t| − |p_{t+1}|) − dφ, w ← w·f_w(m), normalised; f_w(m) =
   1/max(m², m₀²), m₀ = √(½(4π/λ)² s_r² + s_θ²) (eq. 11): the paper's 1/m², bounded.
4. Resampling (eq. 16): systematic when ESS = 1/Σ wᵢ² < N_th = 2N/3; weights reset to 1/N.
5. Suggested turn (eqs. 23–24), circular: daᵢ = atan2(−yᵢ, −xᵢ) − aᵢ, a_sug = atan2(Σ wᵢ sin daᵢ, Σ
   wᵢ cos daᵢ) (``suggestion='mean'``).

Additions to the paper: ``suggestion='auto'`` (default) takes the heavier side's mean when the mean
resultant length R̄ = |Σ wᵢ e^{i daᵢ}| < ``side_threshold`` (0.9), 'side' always; ``reinit_factor``
redraws the cloud when min |m| > 3 m₀. Off by default: ``update(..., dphi_std=σ)`` (σ replaces s_θ),
``weighting='gaussian'`` (exp(−m²/(2m₀²))) or ``'student_t'`` ((1 + m²/(ν m₀²))^(−(ν+1)/2), ν =
``t_dof``), ``predict(turn)`` (move without weighting), ``init_boost`` (draw ``init_boost``·N prior
particles at the first update and a re-initialisation, keep N). ``tag_posterior()``: the tag in the
user's frame, ``bimodal`` when the lighter side of the walking line holds ≥ ``bimodal_weight`` (0.1)
and both sides' mean |y| exceed twice their std; ``tag_sides()``: both mirror modes with their
probabilities (a straight MOVE weighs (x, y) and (x, −y) alike; a turn then a MOVE moves weight).
Why each choice, and the measurements: docs/results/rfid.md, "The particle filter in full".
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from track_core.filters import effective_sample_size, systematic_resample, wrap_angle
from track_core.filters.poses import relative_pose
from track_core.rfid.phase import PhaseModel

SUGGESTION_RULES = ('mean', 'side', 'auto')
WEIGHTINGS = ('inverse_square', 'gaussian', 'student_t')


@dataclass(frozen=True)
class PFParams:
    """Filter parameters; the user-error values are the paper's worst case (Section VI)."""

    n_particles: int = 100
    s_step: float = 0.5                    # commanded step (m)
    s_r: float = 0.1                       # step-length error std (m)
    s_a: float = math.radians(11.5)        # turn/heading error std per step (rad)
    jitter_std: float | None = None        # eq. 21; default 2 s_r
    weight_floor: float | None = None      # m₀ of the guard; default eq. 11's std
    resample_fraction: float = 2.0 / 3.0   # N_th = fraction · N (eq. 16)
    init_range: tuple[float, float] = (0.3, 15.0)   # prior distance to the tag (m)
    beam_width: float = math.pi            # the tag is within ±beam/2 of the heading at the start
    suggestion: str = 'auto'               # 'mean' (eq. 24, circular), 'side', 'auto' (see the module doc)
    side_threshold: float = 0.9            # 'auto': mean resultant length below which the side rule applies
    reinit_factor: float | None = 3.0      # re-initialise when min |m| > factor · m₀ (None: never)
    weighting: str = 'inverse_square'      # f_w: 'inverse_square' (Section V, guarded) or 'gaussian' (module doc)
    bimodal_weight: float = 0.1            # tag_posterior: the lighter mirror side needs this much weight
    t_dof: float = 4.0                     # weighting='student_t': degrees of freedom ν
    init_boost: int = 1                    # (re-)initialisation draws init_boost·N prior samples, keeps N (doc)

    def __post_init__(self) -> None:
        if self.n_particles < 1:
            raise ValueError(f'n_particles must be >= 1, got {self.n_particles}')
        if not (0.0 < self.init_range[0] < self.init_range[1]):
            raise ValueError(f'init_range must be 0 < lo < hi, got {self.init_range}')
        if not (0.0 < self.beam_width <= 2.0 * math.pi):
            raise ValueError(f'beam_width must be in (0, 2π], got {self.beam_width}')
        if self.s_step <= 0.0 or self.s_r < 0.0 or self.s_a < 0.0:
            raise ValueError('s_step must be > 0 and s_r, s_a >= 0')
        if self.suggestion not in SUGGESTION_RULES:
            raise ValueError(f'suggestion must be one of {SUGGESTION_RULES}, got {self.suggestion!r}')
        if self.reinit_factor is not None and self.reinit_factor <= 0.0:
            raise ValueError(f'reinit_factor must be > 0 or None, got {self.reinit_factor}')
        if self.weighting not in WEIGHTINGS:
            raise ValueError(f'weighting must be one of {WEIGHTINGS}, got {self.weighting!r}')
        if not (0.0 < self.bimodal_weight < 0.5):
            raise ValueError(f'bimodal_weight must be in (0, 0.5), got {self.bimodal_weight}')
        if not self.t_dof > 0.0:
            raise ValueError(f't_dof must be > 0, got {self.t_dof}')
        if self.init_boost < 1:
            raise ValueError(f'init_boost must be >= 1, got {self.init_boost}')
        if not (0.0 < self.resample_fraction <= 1.0):
            raise ValueError(f'resample_fraction must be in (0, 1], got {self.resample_fraction}')

    @property
    def jitter(self) -> float:
        return 2.0 * self.s_r if self.jitter_std is None else self.jitter_std

    def floor(self, phase: PhaseModel, dphi_std: float | None = None) -> float:
        """m₀: ``weight_floor``, else eq. 11's std with θ_d's std ``dphi_std`` (default s_θ)."""
        if self.weight_floor is not None:
            return self.weight_floor
        return phase.dphi_noise_std(self.s_r, dphi_std)


@dataclass(frozen=True)
class TagEstimate:
    """The tag relative to the user, from the posterior (``RfidParticleFilter.tag_posterior``).

    ``x``, ``y``: weighted mean of the tag's position in the user's frame (x forward along the facing
    direction, y to the left), over the heavier mirror side when ``bimodal``; ``distance``/``bearing``
    are that point in polar form. ``bimodal``: both sides of the walking line hold a mode (module doc),
    so the tag may be at the mirror image (x, −y); ``side_weight`` is the weight of the side used.
    """

    x: float
    y: float
    distance: float
    bearing: float
    bimodal: bool
    side_weight: float


@dataclass(frozen=True)
class TagMode:
    """One mirror side's mode: the weighted mean tag position in the user's frame (x forward, y left, m) and
    the posterior probability that the tag is on that side of the walking line."""

    x: float
    y: float
    probability: float


@dataclass(frozen=True)
class TagSides:
    """The tag's two mirror modes (``RfidParticleFilter.tag_sides``, module doc): ``left`` (y > 0) and
    ``right``; ``unknown`` when both hold a mode (the side is not yet told apart by the walk)."""

    left: TagMode
    right: TagMode
    unknown: bool

    @property
    def likelier(self) -> TagMode:
        return self.left if self.left.probability >= self.right.probability else self.right

    def describe(self) -> str:
        """One line: the side, or both modes with their probabilities while it is unknown."""
        def mode(name: str, m: TagMode) -> str:
            return f'{name} at ({m.x:.2f}, {m.y:.2f}) m with p = {m.probability:.2f}'

        if self.unknown:
            return (f'tag side unknown (mirror images across the walking line): {mode("left", self.left)} or '
                    f'{mode("right", self.right)}; a turn off the line tells them apart')
        side = 'left' if self.likelier is self.left else 'right'
        return f'tag side known: {mode(side, self.likelier)}'


@dataclass(frozen=True)
class UpdateInfo:
    ess: float              # effective sample size after the weight update (before resampling)
    resampled: bool
    suggested_turn: float   # a_sug (rad), + = counter-clockwise (left)


@dataclass(frozen=True)
class MeasuredMotion:
    """The reader's motion over one MOVE as odometry measured it, in place of the instruction (eqs. 19–20).

    ``before`` (x, y, yaw): the reader's pose at the step's start in its frame at the previous step's end:
    yaw is eq. 19's a_u, and (x, y) any shift with it (a reader off the robot's turning axis, a refused
    step). ``step``: its pose at the step's end in its frame at the step's start: eq. 20's (s_step, 0)
    becomes (x, y), and yaw is the heading change over the step. n_a and r keep their role (s_a, s_r).
    """

    before: tuple[float, float, float] = (0.0, 0.0, 0.0)
    step: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        for name in ('before', 'step'):
            v = tuple(float(x) for x in getattr(self, name))
            if len(v) != 3 or not all(math.isfinite(x) for x in v):
                raise ValueError(f'MeasuredMotion.{name} must be 3 finite numbers (x, y, yaw), got {v!r}')
            object.__setattr__(self, name, v)

    @classmethod
    def between(cls, start, end, previous_end=None) -> MeasuredMotion:
        """From the reader's poses (x, y, yaw) in one fixed frame (odom) at the previous MOVE's end (None:
        the first MOVE), this one's start and its end."""
        before = (0.0, 0.0, 0.0) if previous_end is None else relative_pose(previous_end, start)
        return cls(tuple(before), tuple(relative_pose(start, end)))

    def at_start(self) -> MeasuredMotion:
        """The step alone (particles drawn afresh at the step's start)."""
        return MeasuredMotion(step=self.step)


def initial_particles(n: int, params: PFParams, rng: np.random.Generator) -> np.ndarray:
    """(n, 3) particles in the bottom-left quadrant with the tag inside the beam (see the module doc)."""
    theta = rng.uniform(math.pi, 1.5 * math.pi, n)
    r = rng.uniform(*params.init_range, n)
    x, y = r * np.cos(theta), r * np.sin(theta)
    psi = rng.uniform(-0.5, 0.5, n) * min(params.beam_width, 2.0 * math.pi)
    a = wrap_angle(np.arctan2(-y, -x) + psi)
    return np.column_stack([x, y, a])


def guarded_inverse_square(m: np.ndarray, floor: float) -> np.ndarray:
    """f_w(m) = 1 / max(m², m₀²): the paper's 1/m² (Section V) with the m → 0 guard."""
    m2 = np.square(m)
    return 1.0 / np.maximum(m2, floor * floor)


def suggested_turn(particles: np.ndarray, weights: np.ndarray, rule: str = 'mean', threshold: float = 0.9) -> float:
    """Eqs. 23–24 in circular form: the weighted circular mean of daᵢ = atan2(−yᵢ, −xᵢ) − aᵢ.

    ``rule`` 'mean' is that; 'side' and 'auto' restrict it to the heavier mirror side (module doc).
    """
    da = np.arctan2(-particles[:, 1], -particles[:, 0]) - particles[:, 2]
    return _suggest_from(np.cos(da), np.sin(da), np.asarray(weights, dtype=float), rule, threshold)


def _suggest_from(cda: np.ndarray, sda: np.ndarray, w: np.ndarray, rule: str, threshold: float) -> float:
    """The suggestion from cos daᵢ, sin daᵢ and the weights (see ``suggested_turn``)."""
    sc, ss = float(w @ cda), float(w @ sda)
    if rule == 'mean' or (rule == 'auto' and math.hypot(sc, ss) >= threshold * float(w.sum())):
        return math.atan2(ss, sc)
    left = sda > 0.0
    wl = np.where(left, w, 0.0)
    if 2.0 * float(wl.sum()) < float(w.sum()):
        wl = w - wl
    return math.atan2(float(wl @ sda), float(wl @ cda))


class RfidParticleFilter:
    """The whole filter state (particles, weights, counters), driven one MOVE at a time.

    ``particles`` is (N, 3) = (x, y, a) per row (a view of an internal (3, N) array). Not thread-safe;
    ``snapshot``/``restore`` copy the state, generator included.
    """

    def __init__(self, params: PFParams, phase: PhaseModel, rng: np.random.Generator) -> None:
        self.params = params
        self.phase = phase
        self.rng = rng
        self._P = np.empty((3, 0))
        self.weights = np.empty(0)
        self.n_updates = 0
        self.n_resamples = 0
        self.n_reinits = 0
        self.last_reinit = False
        self._sug: float | None = None      # cached suggestion of the current state

    @property
    def particles(self) -> np.ndarray:
        return self._P.T

    @particles.setter
    def particles(self, value: np.ndarray) -> None:
        v = np.asarray(value, dtype=float)
        if v.ndim != 2 or v.shape[1] != 3:
            raise ValueError(f'particles must be (N, 3), got {v.shape}')
        self._P = np.ascontiguousarray(v.T)
        self._sug = None

    @property
    def initialized(self) -> bool:
        return self._P.shape[1] > 0

    def initialize(self) -> None:
        n = self.params.n_particles
        self.particles = initial_particles(n, self.params, self.rng)
        self.weights = np.full(n, 1.0 / n)
        self.n_updates = self.n_resamples = self.n_reinits = 0

    def snapshot(self) -> tuple:
        return (self._P.copy(), self.weights.copy(), self.n_updates, self.n_resamples, self.n_reinits,
                self.rng.bit_generator.state)

    def restore(self, snap: tuple) -> None:
        P, w, self.n_updates, self.n_resamples, self.n_reinits, state = snap
        self._P, self.weights = P.copy(), w.copy()
        self.rng.bit_generator.state = state
        self._sug = None

    def _move(self, x: np.ndarray, y: np.ndarray, a: np.ndarray, turn: float, e: np.ndarray, dphi: float,
              motion: MeasuredMotion | None = None):
        """Eq. 20 with standard normals ``e`` (rows 2, 3: n_a, r) and eq. 22's m; ``motion``: measured."""
        p = self.params
        if motion is not None:
            return self._measured_move(x, y, a, motion, e, dphi)
        head = a + (turn + p.s_a * e[2])
        c, s = np.cos(head), np.sin(head)
        step = p.s_step + p.s_r * e[3]
        x1, y1 = x + step * c, y + step * s
        r1 = np.sqrt(x1 * x1 + y1 * y1)
        m = self.phase.k * (r1 - np.sqrt(x * x + y * y)) - dphi     # eq. 22: −k(|p_t| − |p_{t+1}|) − dφ
        return x1, y1, head, c, s, r1, m

    def _measured_move(self, x, y, a, motion: MeasuredMotion, e: np.ndarray, dphi: float):
        """Eqs. 19–20 with the measured motion: shift, a_u + n_a, then |step| + r along its direction."""
        p = self.params
        bx, by, byaw = motion.before
        if bx or by:
            c0, s0 = np.cos(a), np.sin(a)
            x, y = x + c0 * bx - s0 * by, y + s0 * bx + c0 * by
        h = a + (byaw + p.s_a * e[2])                                   # eq. 19: a_u measured, n_a
        sx, sy, syaw = motion.step
        along = h + math.atan2(sy, sx)
        step = math.hypot(sx, sy) + p.s_r * e[3]                        # eq. 20: s_step → |step|
        x1, y1 = x + step * np.cos(along), y + step * np.sin(along)
        head = h + syaw
        r1 = np.sqrt(x1 * x1 + y1 * y1)
        m = self.phase.k * (r1 - np.sqrt(x * x + y * y)) - dphi       # eq. 22 from the step's start
        return x1, y1, head, np.cos(head), np.sin(head), r1, m

    def _log_fw(self, m: np.ndarray, m0: float) -> np.ndarray:
        """log f_w(m) of eq. 15 for the ``weighting`` (module doc), up to a constant."""
        p = self.params
        if p.weighting == 'gaussian':
            return -0.5 * np.square(m / m0)
        if p.weighting == 'student_t':
            return -0.5 * (p.t_dof + 1.0) * np.log1p(np.square(m / m0) / p.t_dof)
        return -np.log(np.maximum(np.square(m), m0 * m0))

    def _boosted(self, n: int, turn: float, dphi: float, m0: float, motion: MeasuredMotion | None = None) -> tuple:
        """``init_boost``·n prior particles moved and weighted by ``dphi``; n of them by systematic resampling."""
        rng, nb = self.rng, n * self.params.init_boost
        P0 = initial_particles(nb, self.params, rng)
        out = self._move(P0[:, 0], P0[:, 1], P0[:, 2], turn, rng.standard_normal((4, nb)), dphi, motion)
        lw = self._log_fw(out[-1], m0)
        w = np.exp(lw - lw.max())
        idx = systematic_resample(w / w.sum(), rng, n)
        return tuple(v[idx] for v in out)

    def update(self, dphi: float, turn: float = 0.0, *, force_resample: bool = False,
               dphi_std: float | None = None, motion: MeasuredMotion | None = None) -> UpdateInfo:
        """One MOVE: jitter, motion (a_u = ``turn``), weights from ``dphi``, resampling, suggestion.

        ``dphi_std``: the reader's own std of this dφ (``signal.PhaseProcessor`` with online noise); it
        replaces s_θ in eq. 11's m₀ for this step. None or NaN: the fixed s_θ (the paper).
        ``motion``: the measured motion (odometry, ``MeasuredMotion``) in place of ``turn`` (then 0) and
        ``s_step``; at a re-initialisation only its ``step`` is used.

        Initialises the particles first if needed (the first MOVE). Raises ``ValueError`` for a
        non-finite ``dphi`` or ``turn`` before touching the state. Random draws, in order: one
        (4, N) block of standard normals (jitter x, jitter y, n_a, r; the jitter rows are unused at
        the first update), then the systematic resampling's uniform.
        """
        if not (math.isfinite(dphi) and math.isfinite(turn)):
            raise ValueError(f'update needs a finite dphi and turn, got dphi={dphi!r}, turn={turn!r}')
        if motion is not None and turn != 0.0:
            raise ValueError(f'update takes the turn from motion or from turn, not both (turn={turn!r})')
        if not self.initialized:
            self.initialize()
        p, rng = self.params, self.rng
        x, y, a = self._P
        n = x.size
        e = rng.standard_normal((4, n))
        if self.n_updates > 0 and p.jitter > 0.0:                   # eq. 21 on the previous posterior
            x, y = x + p.jitter * e[0], y + p.jitter * e[1]
        x1, y1, head, c, s, r1, m = self._move(x, y, a, turn, e, dphi, motion)
        m0 = p.floor(self.phase, dphi_std if dphi_std is not None and math.isfinite(dphi_std) else None)
        w = self.weights
        self.last_reinit = False
        fresh = self.n_updates == 0
        if self.n_updates > 0 and p.reinit_factor is not None and np.min(np.abs(m)) > p.reinit_factor * m0:
            # no particle explains this step: start afresh at the step's start (tag in the beam there)
            fresh, turn, motion = True, 0.0, None if motion is None else motion.at_start()
            self.n_reinits += 1
            self.last_reinit = True
            if p.init_boost == 1:
                P0 = initial_particles(n, p, rng)
                x1, y1, head, c, s, r1, m = self._move(P0[:, 0], P0[:, 1], P0[:, 2], 0.0,
                                                       rng.standard_normal((4, n)), dphi, motion)
                w = np.full(n, 1.0 / n)
        if fresh and p.init_boost > 1:
            # prior boosting: init_boost·N prior samples weighted by this step, N kept by systematic resampling
            x1, y1, head, c, s, r1, m = self._boosted(n, turn, dphi, m0, motion)
            w = np.full(n, 1.0 / n)
        elif p.weighting == 'inverse_square':
            w = w * guarded_inverse_square(m, m0)                       # eq. 15
        else:                                                           # eq. 15 in logs: cannot underflow to 0
            with np.errstate(divide='ignore'):                         # a weight may have underflowed to 0
                lw = np.log(w) + self._log_fw(m, m0)
            w = np.exp(lw - lw.max())
        w /= w.sum()
        ess = effective_sample_size(w)
        resampled = force_resample or ess < p.resample_fraction * n    # eq. 16
        if resampled:
            idx = systematic_resample(w, rng)
            x1, y1, head, c, s, r1 = x1[idx], y1[idx], head[idx], c[idx], s[idx], r1[idx]
            w = np.full(n, 1.0 / n)
            self.n_resamples += 1
        if self.n_updates % 16 == 15:                                   # keep headings bounded
            head = wrap_angle(head)
        self._P = np.stack([x1, y1, head])
        self.weights = w
        self.n_updates += 1
        # eq. 23 without atan2: e^{i daᵢ} = e^{i(βᵢ − aᵢ)}, cos βᵢ = −xᵢ/rᵢ, sin βᵢ = −yᵢ/rᵢ
        inv = 1.0 / np.maximum(r1, 1e-12)
        self._sug = _suggest_from(-(x1 * c + y1 * s) * inv, (x1 * s - y1 * c) * inv, w, p.suggestion,
                                  p.side_threshold)
        return UpdateInfo(ess, resampled, self._sug)

    def predict(self, turn: float = 0.0, *, motion: MeasuredMotion | None = None) -> None:
        """A MOVE without a usable dφ: jitter (eq. 21) and motion (eqs. 19–20; ``motion`` as in
        ``update``) only, no weights.

        The walk goes on when the reader could not measure a step: the particles follow the commanded
        motion and the next usable dφ weights them, so an invalid MOVE costs that step's information,
        not the walk. Before the first update it initialises the particles at this step's start.
        The weights, the resampling counters and the suggestion's rule are unchanged.
        """
        if not math.isfinite(turn):
            raise ValueError(f'predict needs a finite turn, got {turn!r}')
        if not self.initialized:
            self.initialize()
        p, rng = self.params, self.rng
        x, y, a = self._P
        e = rng.standard_normal((4, x.size))
        if self.n_updates > 0 and p.jitter > 0.0:
            x, y = x + p.jitter * e[0], y + p.jitter * e[1]
        x1, y1, head, *_ = self._move(x, y, a, turn, e, 0.0, motion)
        self._P = np.stack([x1, y1, wrap_angle(head)])
        self.n_updates += 1
        self._sug = None

    def suggested_turn(self) -> float:
        if not self.initialized:
            return 0.0
        if self._sug is None:
            self._sug = suggested_turn(self.particles, self.weights, self.params.suggestion, self.params.side_threshold)
        return self._sug

    def tag_estimate(self) -> tuple[float, float]:
        """The tag relative to the user: (distance m, bearing rad from the facing direction, + = left).

        Distance: weighted mean of |pᵢ|; bearing: a_sug. NaN before the first update.
        """
        if not self.initialized:
            return math.nan, math.nan
        return float(self.weights @ np.hypot(self._P[0], self._P[1])), self.suggested_turn()

    def tag_sides(self) -> TagSides:
        """Both mirror modes of the tag in the user's frame and their probabilities (module doc).

        A side with no weight has NaN coordinates and probability 0; NaN everywhere before the first update.
        """
        nan = TagMode(math.nan, math.nan, 0.0)
        if not self.initialized:
            return TagSides(nan, nan, False)
        fx, fy, w = self._tag_in_user_frame()
        total = float(w.sum())
        modes = []
        for mask in (fy > 0.0, fy <= 0.0):
            ws = float(w[mask].sum())
            modes.append(TagMode(float(w[mask] @ fx[mask]) / ws, float(w[mask] @ fy[mask]) / ws, ws / total)
                         if ws > 0.0 else nan)
        return TagSides(modes[0], modes[1], self.tag_posterior().bimodal)

    def _tag_in_user_frame(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(fx, fy, w): the tag R(−a)·(0 − p) seen from each particle, and the weights."""
        x, y, a = self._P
        c, s = np.cos(a), np.sin(a)
        return -(c * x + s * y), s * x - c * y, self.weights

    def tag_posterior(self) -> TagEstimate:
        """The tag's position in the user's frame, and whether the posterior is two-sided (module doc).

        NaN fields before the first update.
        """
        if not self.initialized:
            return TagEstimate(math.nan, math.nan, math.nan, math.nan, False, math.nan)
        fx, fy, w = self._tag_in_user_frame()
        left = fy > 0.0
        sides = []
        for mask in (left, ~left):
            ws = float(w[mask].sum())
            if ws > 0.0:
                my = float(w[mask] @ fy[mask]) / ws
                sd = math.sqrt(max(float(w[mask] @ np.square(fy[mask] - my)) / ws, 0.0))
                sides.append((ws, mask, abs(my) / max(sd, 1e-12)))
        ws, mask, _ = max(sides, key=lambda e: e[0])
        bimodal = (len(sides) == 2 and min(e[0] for e in sides) >= self.params.bimodal_weight
                   and min(e[2] for e in sides) > 2.0)
        if not bimodal:
            ws, mask = float(w.sum()), np.ones_like(left)
        tx, ty = float(w[mask] @ fx[mask]) / ws, float(w[mask] @ fy[mask]) / ws
        return TagEstimate(tx, ty, math.hypot(tx, ty), math.atan2(ty, tx), bool(bimodal), ws / float(w.sum()))


def loop_update(particles: list[list[float]], weights: list[float], dphi: float, turn: float, params: PFParams,
                phase: PhaseModel, rng: np.random.Generator, first: bool = False,
                noise: np.ndarray | None = None, resample_u: float | None = None,
                resampling: str = 'multinomial') -> tuple[list, list, float]:
    """The same update written one particle at a time in Python: the baseline of ``track-bench rfid``.

    Per particle: four scalar normal draws, eq. 21 jitter, eq. 20, eq. 22, eq. 15; then the
    normalisation; then resampling (always, as the benchmark forces it); then eqs. 23–24 with
    ``math.atan2`` per particle. ``resampling='multinomial'`` is §IV.A.3 as written ("a number of
    random particles is taken with replacement"): N uniform draws, each located by a linear scan of
    the cumulative weights, O(N²). That is the straightforward prototype, and it is consistent with
    the paper's times growing faster than N (90.7 ms at N = 300, 473.9 ms at N = 1000).
    ``'systematic'`` is the O(N) scheme that ``RfidParticleFilter`` uses. Given ``noise`` ((N, 4)
    standard normals: jitter x, jitter y, n_a, r), ``resample_u`` and ``resampling='systematic'``,
    it reproduces ``RfidParticleFilter.update(..., force_resample=True)`` with the 'mean' rule
    (the tests check this). Returns (particles, weights, a_sug).
    """
    n = len(particles)
    k = phase.k
    m0 = params.floor(phase)
    jit = params.jitter
    new, w = [], []
    for i in range(n):
        x, y, a = particles[i]
        e = [rng.normal(), rng.normal(), rng.normal(), rng.normal()] if noise is None else noise[i]
        if not first:
            x += jit * e[0]
            y += jit * e[1]
        head = a + (turn + params.s_a * e[2])
        step = params.s_step + params.s_r * e[3]
        x1 = x + step * math.cos(head)
        y1 = y + step * math.sin(head)
        mi = k * (math.sqrt(x1 * x1 + y1 * y1) - math.sqrt(x * x + y * y)) - dphi
        w.append(weights[i] / max(mi * mi, m0 * m0))
        new.append([x1, y1, head])
    s = sum(w)
    w = [wi / s for wi in w]
    out = []
    if resampling == 'multinomial':
        for _ in range(n):
            u, j, cum = rng.random(), 0, w[0]
            while cum < u and j < n - 1:
                j += 1
                cum += w[j]
            out.append(list(new[j]))
    else:
        u0 = rng.random() if resample_u is None else resample_u
        cum, j = w[0], 0
        for i in range(n):
            pos = (u0 + i) / n
            while pos >= cum and j < n - 1:
                j += 1
                cum += w[j]
            out.append(list(new[j]))
    w = [1.0 / n] * n
    sx = sc = 0.0
    for i in range(n):
        x, y, a = out[i]
        da = math.atan2(-y, -x) - a
        sx += w[i] * math.sin(da)
        sc += w[i] * math.cos(da)
    return out, w, math.atan2(sx, sc)

"""Covariance-control sensor scheduling, the paper's eq. 7 (after Kalandros & Pao's norm/sensors rule).

After step k the filter's output covariance Cov_k is compared with the desired covariance P_D: use
the active sensor at step k+1 if ‖P_D − Cov_k‖₂ > δ (spectral norm, the largest singular value),
otherwise the passive one. The first step is active (Algorithm 3, initialisation).

P_D: Table 1 prints "diag([5 0.25 0.2])" for a 4-dimensional state (garbled). We read one [position,
velocity] block per axis: ``DEFAULT_P_D = diag([5, 0.25, 5, 0.25])`` in the state order [x, ẋ, y, ẏ]
(m², (m/s)²), the trailing "0.2" a truncated repeat of 0.25 (‖P_D − Cov‖₂ is dominated by the
position eigenvalues, so it changes nothing). P_D is a parameter: any symmetric PSD 4×4 matrix, or a
length-4 vector for its diagonal. ``Reading`` (``sonar-table2 --reading``) selects other readings:
variances or standard deviations, two-sided or one-sided ('excess': λmax(Cov − P_D) > δ), the full
matrix or the position block, posterior or predicted covariance.

Table 2's δ = 5 keeps the active sonar on here: by Weyl, ‖P_D − Cov‖₂ ≥ λmax(Cov) − 5, and the
posterior Cramér–Rao bound of an always-active sonar keeps λmax(Cov) above 10 m². The closed-loop
experiment and the node use δ = 50 (about the paper's ping count).

``initial_pings`` (default 1 = Algorithm 3's initialisation; beyond the paper): the first
``initial_pings`` steps are active whatever Cov, then eq. 7 decides (a second reading averages out a
first reading's range error, which eq. 7 cannot see). The bound, the readings and the counts:
docs/results/sonar.md, "The scheduler".
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from track_core.filters import check_covariance
from track_core.sonar.models import SensorMode, SonarParams

METRICS = ('spectral', 'excess')
BLOCKS = ('full', 'position')
COV_KINDS = ('posterior', 'predicted')
P_D_UNITS = ('variance', 'std')
#: δ of eq. 7, Table 1 (the default of every scheduler, tracker and of the sonar_observer node)
DELTA = 5.0
DEFAULT_P_D = np.diag([5.0, 0.25, 5.0, 0.25])
POS = [0, 2]


@dataclass(frozen=True)
class Reading:
    """One reading of eq. 7 and Table 1's P_D (``sonar-table2 --reading``).

    - ``p_d``: 'variance' (diag(5, 0.25, 5, 0.25), the default) or 'std' (Table 1's numbers as
      standard deviations, P_D = diag(25, 0.0625, 25, 0.0625));
    - ``metric``: 'spectral' ‖P_D − Cov‖₂ (eq. 7 as printed) or 'excess' λmax(Cov − P_D) (one-sided);
    - ``block``: 'full' 4×4, or 'position' (the [x, y] blocks of P_D and Cov only);
    - ``cov``: 'posterior' Cov(x_k) (Algorithm 3) or 'predicted' F Cov Fᵀ + Q (the covariance the
      next step would have without a measurement).
    """

    p_d: str = 'variance'
    metric: str = 'spectral'
    block: str = 'full'
    cov: str = 'posterior'

    def __post_init__(self) -> None:
        for name, allowed in (('p_d', P_D_UNITS), ('metric', METRICS), ('block', BLOCKS), ('cov', COV_KINDS)):
            if getattr(self, name) not in allowed:
                raise ValueError(f'reading {name} must be one of {allowed}, got {getattr(self, name)!r}')

    @classmethod
    def parse(cls, text: str | None) -> Reading:
        """'std,excess,position' → Reading; words in any order, each one value of a field; ''/None = default."""
        fields: dict[str, str] = {}
        for word in (w.strip().lower() for w in (text or '').split(',')):
            if not word:
                continue
            hits = [name for name, allowed in (('p_d', P_D_UNITS), ('metric', METRICS), ('block', BLOCKS),
                                               ('cov', COV_KINDS)) if word in allowed]
            if not hits:
                raise ValueError(f'reading: unknown word {word!r}; allowed {P_D_UNITS + METRICS + BLOCKS + COV_KINDS}')
            if hits[0] in fields:
                raise ValueError(f'reading: two values for {hits[0]} ({fields[hits[0]]!r}, {word!r})')
            fields[hits[0]] = word
        return cls(**fields)

    @property
    def label(self) -> str:
        return ','.join((self.p_d, self.metric, self.block, self.cov))

    @property
    def P_D(self) -> np.ndarray:  # noqa: N802 - the paper's symbol
        return DEFAULT_P_D**2 if self.p_d == 'std' else DEFAULT_P_D.copy()

    def scheduler_kwargs(self) -> dict:
        return {'P_D': self.P_D, 'metric': self.metric, 'block': self.block, 'cov_kind': self.cov}


def desired_covariance(P_D: np.ndarray | list | tuple | None) -> np.ndarray:
    """Validate P_D (4×4 symmetric PSD, or a length-4 diagonal); ``ValueError`` names 'P_D'."""
    if P_D is None:
        return DEFAULT_P_D.copy()
    P = np.asarray(P_D, dtype=float)
    if P.shape == (4,):
        P = np.diag(P)
    if P.shape != (4, 4):
        raise ValueError(f'P_D must be a 4x4 matrix or a length-4 diagonal, got shape {P.shape}')
    return check_covariance(P, 'P_D')


@dataclass(frozen=True)
class SchedulerConfig:
    """The settings of eq. 7, defaults Table 1's and Algorithm 3's: threshold ``delta`` δ [m²], desired
    covariance ``P_D`` (4 numbers: its diagonal; 16: a row-major 4×4; kept as its diagonal when diagonal),
    the distance (``metric``, ``block``, ``cov_kind``: see ``Reading``) and ``initial_pings``, the
    active steps at the start before eq. 7 decides."""

    delta: float = DELTA
    P_D: tuple[float, ...] = tuple(np.diag(DEFAULT_P_D).tolist())
    metric: str = 'spectral'
    block: str = 'full'
    cov_kind: str = 'posterior'
    initial_pings: int = 1

    def __post_init__(self) -> None:
        if not (isinstance(self.initial_pings, int | np.integer) and self.initial_pings >= 1):
            raise ValueError(f'initial_pings must be an integer >= 1, got {self.initial_pings!r}')
        for name, allowed in (('metric', METRICS), ('block', BLOCKS), ('cov_kind', COV_KINDS)):
            if getattr(self, name) not in allowed:
                raise ValueError(f'{name} must be one of {allowed}, got {getattr(self, name)!r}')
        d = self.delta
        if not (isinstance(d, int | float | np.floating | np.integer) and math.isfinite(d) and d >= 0):
            raise ValueError(f'delta must be a finite number >= 0, got {d!r}')
        P = desired_covariance(DEFAULT_P_D if self.P_D is None else _square(self.P_D))
        diagonal = np.array_equal(P, np.diag(np.diag(P)))
        object.__setattr__(self, 'P_D', tuple((np.diag(P) if diagonal else P.ravel()).tolist()))

    @property
    def P_D_matrix(self) -> np.ndarray:  # noqa: N802 - the paper's symbol
        """P_D as the 4×4 matrix."""
        return desired_covariance(_square(self.P_D))


def _square(P_D) -> np.ndarray:
    """16 numbers as the row-major 4×4 matrix; anything else as it is (``desired_covariance`` checks it)."""
    P = np.asarray(P_D, dtype=float)
    return P.reshape(4, 4) if P.shape == (16,) else P


class CovarianceScheduler:
    """Eq. 7 with the settings of ``config`` (``SchedulerConfig``; ``fields`` override its fields by name,
    ``P_D`` and ``delta`` may be positional): ``decide(cov)`` returns the sensor for the next step and
    remembers it.

    ``next_mode`` is the mode to use at the coming step (ACTIVE before the first step); with ``first``
    ACTIVE the first ``initial_pings`` steps are active whatever Cov (module docstring). ``params``: the
    F and Q of the predicted covariance (``cov_kind`` 'predicted').
    """

    def __init__(self, *args, config: SchedulerConfig | None = None, first: SensorMode | str = SensorMode.ACTIVE,
                 params: SonarParams | None = None, **fields) -> None:
        if len(args) > 2:
            raise TypeError(f'CovarianceScheduler takes at most 2 positional settings (P_D, delta), got {len(args)}')
        config = config or SchedulerConfig()
        fields = {**dict(zip(('P_D', 'delta'), args, strict=False)), **fields}
        fields = {k: v for k, v in fields.items() if v is not None or k != 'P_D'}   # P_D None: the default
        self.config = c = dataclasses.replace(config, **fields) if fields else config
        self.initial_pings = int(c.initial_pings)
        self.steps = 0
        self.metric, self.block, self.cov_kind = c.metric, c.block, c.cov_kind
        p = params or SonarParams()
        self._F, self._Q = p.F, p.Q
        self.P_D = c.P_D_matrix
        self.delta = float(c.delta)
        self.first = SensorMode.parse(first)
        self.next_mode = self.first

    def reset(self) -> None:
        self.next_mode = self.first
        self.steps = 0

    def distance(self, cov: np.ndarray) -> float:
        """'spectral': ‖P_D − Cov‖₂ (largest singular value, eq. 7); 'excess': λ_max(Cov − P_D).

        ``cov_kind='predicted'`` uses F Cov Fᵀ + Q; ``block='position'`` the [x, y] blocks only.
        """
        C = np.asarray(cov, dtype=float)
        if self.cov_kind == 'predicted':
            C = self._F @ C @ self._F.T + self._Q
        P_D = self.P_D
        if self.block == 'position':
            C, P_D = C[np.ix_(POS, POS)], P_D[np.ix_(POS, POS)]
        diff = P_D - C
        if self.metric == 'excess':
            return float(-np.linalg.eigvalsh(0.5 * (diff + diff.T))[0])
        return float(np.linalg.norm(diff, ord=2))

    def decide(self, cov: np.ndarray) -> SensorMode:
        """Eq. 7 after step ``steps``; the first ``initial_pings`` steps are active whatever Cov."""
        self.steps += 1
        start = self.first is SensorMode.ACTIVE and self.steps < self.initial_pings
        self.next_mode = (SensorMode.ACTIVE if start or self.distance(cov) > self.delta else SensorMode.PASSIVE)
        return self.next_mode


class FixedScheduler:
    """Always the same sensor: the PaPF (passive) and AcPF (active) baselines of Section 5."""

    def __init__(self, mode: SensorMode | str) -> None:
        self.first = SensorMode.parse(mode)
        self.next_mode = self.first

    def reset(self) -> None:
        self.next_mode = self.first

    def decide(self, cov: np.ndarray) -> SensorMode:
        return self.next_mode

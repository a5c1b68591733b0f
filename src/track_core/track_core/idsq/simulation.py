"""The §5.1 simulation: sensor field, vehicle truth, measurements, and whole-track runs.

Interpretations:

- "K/4 rows and four columns, evenly covering the field": sensor (row i, column j) sits at the
  centre of its block, ((j + ½)·W/4, (i + ½)·H/(K/4)), then N(0, 25) is added to each
  coordinate; positions are not clipped to the field. K must be a multiple of 4.
  N(0, 25) is read as *variance* 25 m² (σ = 5 m): the paper writes the acoustic noise as
  N(0, 0.05²), i.e. N(mean, variance). The neighbourhood column of Table 4 agrees: with σ = 5 m
  our leaders' mean |N| is 2.06 / 3.09 / 5.81 at K = 24 / 40 / 64 (paper 2.0 / 3.0 / 6.0);
  with σ = 25 m it is 2.33 / 3.23 / 5.92 and the layout is no longer a grid.
- DOA fraction f: round(f·K) sensors, chosen uniformly without replacement, are DOA.
- Vehicle: x = W/2, entering at the south edge y = 0 at t = 0 and moving north at 7 m/s; one
  tracker step per Δt = 0.5 s while the vehicle is in the field (72 steps for H = 250 m).
- Table 4 statistics ("averaged over all tracking steps and twenty runs"; Fig. 9: per-run means
  over the steps, then the mean over runs — the same number, every run having 72 steps):
  ‖x̂_MMSE − x‖ of the posterior of every step including the first (uniform start, so the
  first steps of the "discovery" phase are counted, as the paper says it counts all steps),
  the weighted spread, the stored cell count, and |N| after the triplet rule.
- Every run draws one standard normal per sensor and step; each tracker (IDSQ with any
  selection rule, centralized) uses the same draws (common random numbers), so baselines are
  compared on the same runs. The t = 0 amplitude reading of every sensor (start-leader rule) uses
  the t = 0 draw.
- Measurements travel as the decoded handoff (float32 masses), exactly as a node would receive
  them; bytes per step = length of the encoded handoff. Centralized bytes per step = K
  measurement messages of ``MEAS_MSG_BYTES`` (sender u16, step u32, z f32) to the fusion centre
  (Table 2 counts O(K·belief) when sensors ship likelihoods instead; we count the cheaper case).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from track_core.idsq.config import LeaderConfig
from track_core.idsq.grid import GridSpec, SparseBelief, estimate, uniform_belief
from track_core.idsq.handoff import decode_handoff
from track_core.idsq.models import SimNoise, TrackerParams, amplitude_readings, simulate_measurement
from track_core.idsq.network import SensorLayout, start_leader
from track_core.idsq.tracker import centralized_step, leader_step

MEAS_MSG_BYTES = 10


@dataclass(frozen=True)
class Scenario:
    """§5.1 settings (defaults are the paper's)."""

    n_sensors: int = 40
    doa_fraction: float = 0.3
    width: float = LeaderConfig.width
    height: float = LeaderConfig.height
    jitter_var: float = 25.0
    speed: float = 7.0
    comm_range: float = LeaderConfig.comm_range
    noise: SimNoise = field(default_factory=SimNoise)
    tracker: TrackerParams = field(default_factory=TrackerParams)

    def __post_init__(self) -> None:
        if self.n_sensors < 8 or self.n_sensors % 4:
            raise ValueError(f'n_sensors={self.n_sensors} must be a multiple of 4 and >= 8')
        if not 0.0 <= self.doa_fraction <= 1.0:
            raise ValueError(f'doa_fraction={self.doa_fraction} must be in [0, 1]')
        if not (self.speed > 0 and self.jitter_var >= 0):
            raise ValueError(f'speed={self.speed} must be > 0 and jitter_var={self.jitter_var} >= 0')

    @property
    def grid(self) -> GridSpec:
        return GridSpec.for_field(self.width, self.height, LeaderConfig.cell)

    @property
    def n_steps(self) -> int:
        return int(np.floor(self.height / (self.speed * self.tracker.dt))) + 1

    def truth(self) -> np.ndarray:
        """(T, 2) vehicle positions at the tracker steps."""
        y = self.speed * self.tracker.dt * np.arange(self.n_steps)
        return np.stack([np.full_like(y, self.width / 2), y], axis=1)

    def layout(self, rng: np.random.Generator) -> SensorLayout:
        rows = self.n_sensors // 4
        gx = (np.arange(4) + 0.5) * self.width / 4
        gy = (np.arange(rows) + 0.5) * self.height / rows
        pos = np.stack(np.meshgrid(gx, gy), axis=-1).reshape(-1, 2)
        pos = pos + np.sqrt(self.jitter_var) * rng.standard_normal(pos.shape)
        doa = np.zeros(self.n_sensors, bool)
        doa[rng.choice(self.n_sensors, round(self.doa_fraction * self.n_sensors), replace=False)] = True
        return SensorLayout(pos, doa, self.comm_range)


@dataclass(frozen=True)
class RunDraws:
    """One run's randomness: layout, truth and a standard normal per (step, sensor)."""

    layout: SensorLayout
    truth: np.ndarray
    normals: np.ndarray
    select_seed: np.random.SeedSequence

    def measurement(self, sc: Scenario, t: int, k: int) -> float:
        return simulate_measurement(self.truth[t], self.layout.positions[k], bool(self.layout.is_doa[k]),
                                    sc.noise, float(self.normals[t, k]))

    def measurements(self, sc: Scenario, t: int) -> np.ndarray:
        """(K,) every sensor's measurement of step ``t`` (the centralized input); scalar per sensor, like a
        node's, so the values are the leader's bit for bit."""
        return np.array([self.measurement(sc, t, k) for k in range(self.layout.n)])


def draw_run(sc: Scenario, seed: np.random.SeedSequence) -> RunDraws:
    # derived without ``seed.spawn`` (which advances the seed's state): same seed → same run
    s_layout, s_noise, s_sel = (np.random.SeedSequence(seed.entropy, spawn_key=(*seed.spawn_key, j))
                                for j in range(3))
    layout = sc.layout(np.random.default_rng(s_layout))
    normals = np.random.default_rng(s_noise).standard_normal((sc.n_steps, sc.n_sensors))
    return RunDraws(layout, sc.truth(), normals, s_sel)


@dataclass
class TrackResult:
    """Per-step records of one tracker on one run."""

    error: np.ndarray
    spread: np.ndarray
    size: np.ndarray
    block_spread: np.ndarray
    neighbourhood: np.ndarray
    bytes: np.ndarray
    leaders: np.ndarray
    estimates: np.ndarray
    snapshots: dict[int, tuple[SparseBelief, int, np.ndarray]] = field(default_factory=dict)


def _empty(T: int) -> TrackResult:
    return TrackResult(np.empty(T), np.empty(T), np.empty(T), np.empty(T), np.zeros(T), np.empty(T),
                       np.full(T, -1), np.empty((T, 2)))


def start_leader_at(layout: SensorLayout, sources: np.ndarray, noise: SimNoise, std_normals: np.ndarray) -> int:
    """§5.1 start leader from the step-0 amplitude readings, one standard normal per sensor.

    ``sources``: one source (2,) or several (M, 2); each sensor hears its loudest (nearest) one.
    """
    return start_leader(layout, amplitude_readings(sources, layout.positions, noise, std_normals))


def start(sc: Scenario, d: RunDraws) -> int:
    """§5.1 start leader from the t = 0 amplitude readings."""
    return start_leader_at(d.layout, d.truth[0], sc.noise, d.normals[0])


def run_idsq(sc: Scenario, d: RunDraws, selection: str = 'mi', snapshot_steps: tuple[int, ...] = ()) -> TrackResult:
    """One whole track with the leader-based tracker (Table 1), starting from a uniform belief."""
    rng = np.random.default_rng(d.select_seed)
    res = _empty(sc.n_steps)
    belief = uniform_belief(sc.grid)
    leader, prev = start(sc, d), None
    for t in range(sc.n_steps):
        z = d.measurement(sc, t, leader)
        out = leader_step(belief, z, leader, d.layout, sc.tracker, step=t, previous=prev,
                          selection=selection, rng=rng)
        e = out.estimate
        res.error[t] = np.linalg.norm(e.mean - d.truth[t])
        res.spread[t], res.size[t], res.estimates[t], res.block_spread[t] = e.spread, e.size, e.mean, e.block_spread
        res.neighbourhood[t], res.bytes[t], res.leaders[t] = out.neighbourhood_size, len(out.payload), leader
        if t in snapshot_steps:
            res.snapshots[t] = (out.belief, leader, out.candidates)
        belief = decode_handoff(out.payload).belief()
        prev, leader = leader, out.next_leader
    return res


def run_centralized(sc: Scenario, d: RunDraws) -> TrackResult:
    """Same run, every sensor fused each step (§2.2)."""
    res = _empty(sc.n_steps)
    belief = uniform_belief(sc.grid)
    for t in range(sc.n_steps):
        belief, e = centralized_step(belief, d.measurements(sc, t), d.layout, sc.tracker)
        res.error[t] = np.linalg.norm(e.mean - d.truth[t])
        res.spread[t], res.size[t], res.estimates[t], res.block_spread[t] = e.spread, e.size, e.mean, e.block_spread
        res.bytes[t] = sc.n_sensors * MEAS_MSG_BYTES
    return res


def summary(results: list[TrackResult]) -> dict[str, float]:
    """Averages over all steps and runs (Table 4)."""
    cat = {k: np.concatenate([getattr(r, k) for r in results]) for k in ('error', 'spread', 'size',
                                                                         'neighbourhood', 'bytes', 'block_spread')}
    return {'mmse_error_m': float(cat['error'].mean()), 'belief_spread_m2': float(cat['spread'].mean()),
            'block_spread_m2': float(cat['block_spread'].mean()),
            'belief_size': float(cat['size'].mean()), 'neighborhood_size': float(cat['neighbourhood'].mean()),
            'bytes_per_step': float(cat['bytes'].mean())}


__all__ = ['MEAS_MSG_BYTES', 'RunDraws', 'Scenario', 'TrackResult', 'draw_run', 'estimate', 'run_centralized',
           'run_idsq', 'start', 'start_leader_at', 'summary']


def scenario_of(seed: int = 0, n_sensors: int = 24, doa_fraction: float = 0.3, width: float | None = None,
                height: float | None = None, jitter_var: float | None = None, speed: float | None = None,
                dt: float | None = None) -> tuple[Scenario, SensorLayout, np.ndarray]:
    """The §5.1 scenario, its seeded layout and the (T, 2) truth of every tracker step (``vehicle_sim``'s
    draw: ``draw_run(Scenario(...), SeedSequence(seed))``); ``None`` keeps ``Scenario``'s default."""
    d = Scenario()
    sc = Scenario(n_sensors=n_sensors, doa_fraction=doa_fraction, width=d.width if width is None else width,
                  height=d.height if height is None else height,
                  jitter_var=d.jitter_var if jitter_var is None else jitter_var,
                  speed=d.speed if speed is None else speed,
                  tracker=TrackerParams(dt=d.tracker.dt if dt is None else dt))
    run = draw_run(sc, np.random.SeedSequence(seed))
    return sc, run.layout, run.truth

"""Parameters of ``sonar_observer`` (module docstring of ``track_nodes.sonar.sonar_observer``) and what
they build: the desired covariance P_D of eq. 7, the filter's target model and its tracker.

The tracker's settings are ``track_core.sonar.SSPFConfig``, ``SchedulerConfig`` and ``SonarParams``,
declared under the node's flat parameter names (``delta``, ``P_D``, ...: the names users set) with
their defaults; ``sspf_config`` / ``scheduler_config`` map the parameters back to them."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from track_core.sonar import SchedulerConfig, SmartTargetParams, SonarParams, SSPFConfig, desired_covariance
from track_core.sonar.scheduler import METRICS
from track_core.sonar.sspf import PREDICTIONS, SSPF, TRACKERS, make_tracker
from track_nodes.base import ParameterError, param

TARGET_MODELS = ('cv', 'smart')
_SMART = SmartTargetParams()
_SCHED, _SSPF, _SONAR = SchedulerConfig(), SSPFConfig(), SonarParams()
# The node parameter of each field of the SS-PF's target model (``SmartTargetParams``).
MODEL_PARAMS = {**{f: 'model_' + f for f in ('p_max', 'r_50', 'width', 'evade_speed', 'max_accel', 'quiet_period')},
                'max_turn_rate': 'model_max_turn_rate_deg'}


@dataclass
class SonarObserverParams:
    """Parameters of ``sonar_observer``."""

    seed: int = param(0, 'seed of the particle filter (the second of two spawned streams; sonar_sim draws the first)',
                      0, 2**31 - 1)
    tracker: str = param('ss-pf', 'ss-pf: eq. 7 scheduling; papf: passive only; acpf: active only', choices=TRACKERS)
    delta: float = param(_SCHED.delta, 'threshold δ of eq. 7 (Table 1: 5) [m²]', 0.0, 1e12, live=True)
    P_D: list[float] = param(list(_SCHED.P_D), 'desired covariance P_D of eq. 7 in [x, vx, y, '
                             'vy]: 4 values (diagonal) or 16 (row-major 4x4), symmetric PSD')
    metric: str = param(_SCHED.metric, 'eq. 7 distance: spectral ‖P_D − Cov‖₂ (paper) or excess λmax(Cov − P_D)',
                        choices=METRICS)
    initial_pings: int = param(_SCHED.initial_pings, 'active steps at the start before eq. 7 decides (Algorithm 3: 1; '
                               'track_core.sonar.scheduler)', 1, 1000)
    target_model: str = param('cv', "the filter's target model: cv (eqs. 1-4) or smart (the target evades when it "
                              'hears a ping; the model_* parameters)', choices=TARGET_MODELS)
    prediction: str = param(_SSPF.prediction, 'smart model: each particle predicted through the manoeuvre by its sigma '
                            'points (unscented) or by its mean with F P Fᵀ + Q (linear)', choices=PREDICTIONS)
    model_p_max: float = param(_SMART.p_max, 'smart model: detection probability of a ping at close range', 0.0, 1.0)
    model_r_50: float = param(_SMART.r_50, 'smart model: range at which a ping is heard with probability p_max/2 [m]',
                              1e-3, 1e7)
    model_width: float = param(_SMART.width, 'smart model: width of the logistic fall-off of P_det [m]', 1e-3, 1e7)
    model_evade_speed: float = param(_SMART.evade_speed, 'smart model: speed while evading [m/s]', 0.0, 1e3)
    model_max_turn_rate_deg: float = param(math.degrees(_SMART.max_turn_rate), 'smart model: bounded turn rate '
                                           '[deg/s]', 0.0, 360.0)
    model_max_accel: float = param(_SMART.max_accel, 'smart model: bounded speed change [m/s²]', 0.0, 1e3)
    model_quiet_period: float = param(_SMART.quiet_period, 'smart model: time without a heard ping before cruising '
                                      'again [s]', 0.0, 1e6)
    n_particles: int = param(_SONAR.n_particles, 'number of particles N (Table 1: 200)', 1, 1_000_000)
    regularize: bool = param(_SSPF.regularize, 'Liu-West move after resampling (track_core.sonar.sspf; not in the '
                             'paper)')
    period: float = param(_SONAR.T, 'scheduling period T (Table 1: 1 s): a predict-only step for each period without a '
                          'contact; the prior is one period before the first contact [s]', 1e-3, 60.0)
    q_s: float = param(_SONAR.q_s, 'process-noise intensity q_s of the filter model (Table 1: 1) [m²/s³]', 1e-9, 1e3)
    prior_mean: list[float] = param([300.0, 12.25, 300.0, -12.25], 'prior mean m₀ = [x, vx, y, vy] one period '
                                    'before the first contact [m, m/s]')
    prior_pos_std: float = param(20.0, 'prior position std per axis [m]', 1e-6, 1e6)
    prior_vel_std: float = param(2.0, 'prior velocity std per axis [m/s]', 1e-6, 1e6)
    world_frame: str = param('map', 'world frame: of the navigation, of true bearings and of the estimate')
    body_frame: str = param('base_link', "the ship's body frame: a contact in it is a bearing relative to the "
                            "ship's heading")
    nav_wait: float = param(1.0, 'node-clock seconds a contact waits for a navigation fix at or after its stamp, '
                            'then the last fix is extrapolated [s]', 0.0, 1e6, live=True)
    nav_max_age: float = param(2.0, 'the last navigation fix may be this much older than a contact [s]', 0.0, 1e6,
                               live=True)
    coast_after: float = param(2.0, 'node-clock seconds past a due period without a contact before a predict-only '
                               'step is taken; 0 = only when the next contact comes (lock-step runs) [s]', 0.0, 1e6,
                               live=True)
    track_id: str = param('sonar_track', 'child_frame_id of the estimate')
    stamp_lead: float = param(3.0, 'look-ahead tolerance: refuse contacts and fixes stamped more than this ahead of '
                              'the node clock [s]', 1e-3, 1e9, live=True)



def p_d(values) -> np.ndarray:
    v = np.asarray(values, dtype=float)
    if v.size not in (4, 16):
        raise ParameterError(f'parameter P_D has {v.size} values: allowed 4 (diagonal) or 16 (row-major 4x4)')
    try:
        return desired_covariance(v if v.size == 4 else v.reshape(4, 4))
    except ValueError as exc:
        raise ParameterError(f'parameter P_D={v.tolist()!r} is invalid ({exc}): allowed a symmetric PSD '
                             'matrix') from None


def smart_target_params(p, prefix: str = '') -> SmartTargetParams:
    """``SmartTargetParams`` of node parameters named ``<prefix>p_max``, ``<prefix>r_50``, ... (turn rate in
    deg/s): ``smart_target``'s own (no prefix) and the observer's model of it (``model_``)."""
    def get(name):
        return getattr(p, prefix + name)
    return SmartTargetParams(p_max=get('p_max'), r_50=get('r_50'), width=get('width'), evade_speed=get('evade_speed'),
                             max_turn_rate=math.radians(get('max_turn_rate_deg')), max_accel=get('max_accel'),
                             quiet_period=get('quiet_period'), naive=getattr(p, prefix + 'naive', False))


def target_model_of(p: SonarObserverParams) -> SmartTargetParams | None:
    """The SS-PF's ``target_model`` of the parameters: None for ``cv``, the ``model_*`` values for ``smart``."""
    return None if p.target_model == 'cv' else smart_target_params(p, 'model_')


def sspf_config(p: SonarObserverParams) -> SSPFConfig:
    """The SS-PF's settings of the parameters (the others: ``SSPFConfig``'s defaults)."""
    return _checked(lambda: SSPFConfig(regularize=p.regularize, prediction=p.prediction,
                                       target_model=target_model_of(p)), MODEL_PARAMS)


def scheduler_config(p: SonarObserverParams) -> SchedulerConfig:
    """Eq. 7's settings of the parameters (``P_D`` checked by ``p_d``)."""
    p_d(p.P_D)
    return _checked(lambda: SchedulerConfig(delta=p.delta, P_D=tuple(p.P_D), metric=p.metric,
                                            initial_pings=p.initial_pings))


def sonar_params(p: SonarObserverParams) -> SonarParams:
    """The filter model's ``SonarParams`` (period T, q_s, N) of the parameters."""
    return _checked(lambda: SonarParams(T=p.period, q_s=p.q_s, n_particles=p.n_particles), {'T': 'period'})


def observer_tracker(p: SonarObserverParams, sonar: SonarParams, rng: np.random.Generator) -> SSPF:
    """The node's tracker (``tracker`` of ``sspf_config`` and ``scheduler_config``), drawing from ``rng``."""
    return make_tracker(p.tracker, sonar, rng, config=sspf_config(p), schedule=scheduler_config(p))


def _checked(build, names: dict[str, str] | None = None):
    """``build()``; the core's ValueError names the field, i.e. the node's parameter (or ``names[field]``)
    → ParameterError, one line."""
    try:
        return build()
    except ValueError as exc:
        name, _, rest = str(exc).partition(' ')
        raise ParameterError(f'parameter {(names or {}).get(name, name)} {rest}') from None

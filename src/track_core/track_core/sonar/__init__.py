"""Sonar system: smart-target tracking with passive/active sonar (Liu, Ji, Zhang & Hao 2009).

- ``models``: CV target (eqs. 1–4), passive/active sonar (eqs. 5–6), ``SonarParams`` (Table 1).
- ``sspf``: RB-UKF proposal (Algorithm 2, vectorised), ``SSPF`` (Algorithm 3), PaPF/AcPF.
- ``scheduler``: covariance control (eq. 7), the P_D interpretation, ``Reading`` (eq. 7 readings).
- ``ukf``: the UKF peer (ours, from ``filters``) and Stone Soup's UKF behind the SS-PF interface.
- ``gaussian_sum``: the Gaussian-sum UKF, the same-model peer of the smart-target SS-PF.
- ``scenario``: the Section 5 observer trajectory, truth, prior, one Monte-Carlo run.
- ``smart_target``: a target that hears pings (range-dependent) and evades.
- ``lockstep``: when each node of the sonar pair may take its step.
"""

from track_core.sonar.gaussian_sum import GaussianSumUKF
from track_core.sonar.models import SensorMode, SonarParams, bearing, measure, residual, simulate_measurement
from track_core.sonar.scenario import ObserverTrajectory, RunResult, Scenario, run_once
from track_core.sonar.scheduler import (
    DEFAULT_P_D,
    CovarianceScheduler,
    FixedScheduler,
    Reading,
    SchedulerConfig,
    desired_covariance,
)
from track_core.sonar.smart_target import SmartTarget, SmartTargetParams
from track_core.sonar.sspf import SSPF, SonarEstimate, SSPFConfig, make_tracker, rb_ukf
from track_core.sonar.ukf import UKFTracker, make_ukf

__all__ = [
    'DEFAULT_P_D',
    'SSPF',
    'CovarianceScheduler',
    'FixedScheduler',
    'GaussianSumUKF',
    'ObserverTrajectory',
    'Reading',
    'RunResult',
    'SSPFConfig',
    'Scenario',
    'SchedulerConfig',
    'SensorMode',
    'SmartTarget',
    'SmartTargetParams',
    'SonarEstimate',
    'SonarParams',
    'UKFTracker',
    'bearing',
    'desired_covariance',
    'make_tracker',
    'make_ukf',
    'measure',
    'rb_ukf',
    'residual',
    'run_once',
    'simulate_measurement',
]

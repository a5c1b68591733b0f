"""Typed records of the sonar pair (the sonar paper): the observer's sensor mode, the target's status.

- ``SonarMode``: ``/sonar/mode``, one status ``<observer>/sensor_mode`` per step: the mode used at
  t_k, the scheduler's choice for t_{k+1}, the step, the ESS and, for ss-pf, the eq. 7 distance
  ‖P_D − Cov‖ (absent for the baselines);
- ``SonarTargetStatus``: ``/sonar/target/status``, one status named ``track_id`` per step: the
  smart target's mode (naive|cruise|evade), whether it heard a ping at this step, and its counts.
"""

from __future__ import annotations

from dataclasses import dataclass

from track_msgs_py.records import StatusRecord


@dataclass(frozen=True)
class SonarMode(StatusRecord):
    KIND = 'sonar mode'

    mode: str
    next_mode: str
    step: int
    ess: float
    distance: float | None = None


@dataclass(frozen=True)
class SonarTargetStatus(StatusRecord):
    KIND = 'sonar target status'

    mode: str
    heard: bool
    pings: int
    detections: int

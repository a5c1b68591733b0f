"""Parameters of the IDSQ sensor nodes (``acoustic_sensor``, ``doa_sensor``).

The protocol's settings are the core's one configuration (``track_core.idsq.config.LeaderConfig``,
§5.1 defaults), declared under the flat names users set; ``CONFIG_NAMES`` and ``TRACKER_NAMES``
map them to its fields (``sigma_doa_deg`` is ``tracker.sigma_doa`` in degrees), and
``leader_config`` builds it, here and in the offline replay (``report.network_replay``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from track_core.idsq import TrackerParams
from track_core.idsq.config import STARTS, LeaderConfig
from track_core.idsq.leader_protocol import SensorSetup
from track_core.idsq.models import DEG
from track_core.idsq.prediction import PREDICTIONS
from track_core.idsq.tracker import SELECTIONS
from track_nodes.base import ParameterError, param

SENSOR_TYPES = ('acoustic', 'doa')
DURABILITIES = ('volatile', 'transient_local')
_LC = LeaderConfig()
_TP = _LC.tracker
#: node parameter -> its ``LeaderConfig`` field, and -> its ``TrackerParams`` field (plus ``sigma_doa_deg``)
CONFIG_NAMES = {n: n for n in ('width', 'height', 'cell', 'comm_range', 'selection', 'start', 'ack_timeout',
                               'reading_timeout')}
TRACKER_NAMES = {'dt': 'dt', 'v_max': 'v_max', 'a_lo': 'a_lo', 'a_hi': 'a_hi', 'sigma_k': 'sigma_a',
                 'r_near': 'r_near', 'r_far': 'r_far', 'prediction': 'prediction'}


@dataclass
class SensorParams:
    """Parameters of ``acoustic_sensor`` (``DoaSensorParams``: ``doa_sensor``); defaults of §5.1 and the core."""

    id: int = param(0, 'index of this sensor in the layout published by vehicle_sim', 0, 65535)
    position: list[float] = param([0.0, 0.0], 'sensor position [x, y] in map; must equal its layout entry [m]')
    type: str = param('acoustic', 'sensor type; this executable runs acoustic sensors', choices=SENSOR_TYPES)
    seed: int = param(0, 'seed of the random selection baseline (one Generator per (seed, sensor id, step))', 0,
                      2**31 - 1)
    width: float = param(_LC.width, 'field width (x) covered by the grid (§5.1: 150 m) [m]', 1.0, 1e5)
    height: float = param(_LC.height, 'field height (y) covered by the grid (§5.1: 250 m) [m]', 1.0, 1e5)
    cell: float = param(_LC.cell, 'grid cell size (§5.1: 5 m) [m]', 0.1, 1e3)
    dt: float = param(_TP.dt, 'tracker step Δt; the reading of step s is stamped (s + 1)·Δt (§5.1: 0.5 s) [s]',
                      1e-3, 60.0)
    v_max: float = param(_TP.v_max, 'maximum vehicle speed of the diffusion disk (§5.1: 15 m/s) [m/s]', 1e-3, 1e3)
    a_lo: float = param(_TP.a_lo, 'lower bound of the source amplitude prior of eq. 6 (§5.1: 0)', 0.0, 1e6)
    a_hi: float = param(_TP.a_hi, 'upper bound of the source amplitude prior of eq. 6 (§5.1: 80)', 1e-6, 1e6)
    sigma_k: float = param(_TP.sigma_a, 'amplitude noise σ_k of the tracker model, eq. 6 (§5.1: 0.1)', 1e-6, 1e3)
    r_near: float = param(_TP.r_near, 'Fig. 6 DOA model: σ grows below this range (§5.1: 20 m) [m]', 0.0, 1e5)
    r_far: float = param(_TP.r_far, 'Fig. 6 DOA model: σ grows beyond this range (§5.1: 100 m) [m]', 1e-3, 1e5)
    sigma_doa_deg: float = param(_TP.sigma_doa / DEG, 'Fig. 6 DOA σ inside [r_near, r_far] [deg]', 1e-3, 180.0)
    comm_range: float = param(_LC.comm_range, 'radio range of the §5.1 neighbour rule (else the two nearest) [m]',
                              1e-3, 1e6)
    selection: str = param(_LC.selection, 'next-leader rule: mi (Table 1), nearest or random (baselines)',
                           choices=SELECTIONS)
    prediction: str = param(_TP.prediction, 'belief prediction: diffusion (§2.1), or drift / bank (velocity-aware, '
                            'track_core.idsq.prediction)', choices=PREDICTIONS)
    ack_timeout: float = param(_LC.ack_timeout, 'steady-clock wait for an ack before re-selecting [s]', 1e-3, 600.0)
    start: str = param(_LC.start, 'belief of the start leader at step 0: uniform (§5.1) or election (also its '
                       'radio neighbours\' step-0 amplitude readings; track_core.idsq.leader_protocol)', choices=STARTS)
    reading_timeout: float = param(_LC.reading_timeout, 'steady-clock wait for the reading of a step this sensor '
                                   'holds the belief for, then it leads the step predict-only; also the wait for the '
                                   'start election [s]', 1e-3, 3600.0)
    reading_durability: str = param('volatile', 'durability of the reading subscription: volatile (matches any '
                                    'reliable publisher) or transient_local (a late sensor still gets step 0; needs a '
                                    'transient-local publisher, as vehicle_sim\'s)', choices=DURABILITIES)
    track_id: str = param('idsq_track', 'child_frame_id of the estimate')


@dataclass
class DoaSensorParams(SensorParams):
    """Parameters of ``doa_sensor``."""

    type: str = param('doa', 'sensor type; this executable runs doa sensors', choices=SENSOR_TYPES)


#: sensor type -> its parameter dataclass
SENSOR_PARAMS = {'acoustic': SensorParams, 'doa': DoaSensorParams}


_NODE_NAME = {**{f: n for n, f in TRACKER_NAMES.items()}, 'sigma_doa': 'sigma_doa_deg'}


def leader_config(p: SensorParams) -> LeaderConfig:
    """The core's configuration from a sensor node's parameters ``p``; the core's check of a value (e.g.
    a_lo >= a_hi) is one ``ParameterError`` line under the node's name of the field."""
    try:
        tp = TrackerParams(**{f: getattr(p, n) for n, f in TRACKER_NAMES.items()}, sigma_doa=p.sigma_doa_deg * DEG)
        return LeaderConfig(**{f: getattr(p, n) for n, f in CONFIG_NAMES.items()}, tracker=tp)
    except ValueError as exc:
        field, rest = str(exc).partition('=')[::2]
        raise ParameterError(f'parameter {_NODE_NAME.get(field, field)}={rest}' if rest else
                             f'invalid sensor parameters: {exc}') from None


def sensor_setup(p: SensorParams, position: np.ndarray) -> SensorSetup:
    """The ledger's view of a sensor node's checked parameters ``p``."""
    return SensorSetup.of(int(p.id), position, p.type == 'doa', leader_config(p), p.seed)

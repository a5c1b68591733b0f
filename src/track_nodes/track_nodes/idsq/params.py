"""Parameters of the IDSQ sensor nodes (``acoustic_sensor``, ``doa_sensor``): §5.1 defaults."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from track_core.idsq import GridSpec, TrackerParams
from track_core.idsq.leader_protocol import STARTS, SensorSetup
from track_core.idsq.models import DEG
from track_core.idsq.prediction import PREDICTIONS
from track_core.idsq.tracker import SELECTIONS
from track_nodes.base import param

SENSOR_TYPES = ('acoustic', 'doa')
DURABILITIES = ('volatile', 'transient_local')
_TP = TrackerParams()


@dataclass
class SensorParams:
    """Parameters of ``acoustic_sensor`` (``DoaSensorParams``: ``doa_sensor``); defaults of §5.1 and the core."""

    id: int = param(0, 'index of this sensor in the layout published by vehicle_sim', 0, 65535)
    position: list[float] = param([0.0, 0.0], 'sensor position [x, y] in map; must equal its layout entry [m]')
    type: str = param('acoustic', 'sensor type; this executable runs acoustic sensors', choices=SENSOR_TYPES)
    seed: int = param(0, 'seed of the random selection baseline (one Generator per (seed, sensor id, step))', 0,
                      2**31 - 1)
    width: float = param(150.0, 'field width (x) covered by the grid (§5.1: 150 m) [m]', 1.0, 1e5)
    height: float = param(250.0, 'field height (y) covered by the grid (§5.1: 250 m) [m]', 1.0, 1e5)
    cell: float = param(5.0, 'grid cell size (§5.1: 5 m) [m]', 0.1, 1e3)
    dt: float = param(_TP.dt, 'tracker step Δt; the reading of step s is stamped (s + 1)·Δt (§5.1: 0.5 s) [s]',
                      1e-3, 60.0)
    v_max: float = param(_TP.v_max, 'maximum vehicle speed of the diffusion disk (§5.1: 15 m/s) [m/s]', 1e-3, 1e3)
    a_lo: float = param(_TP.a_lo, 'lower bound of the source amplitude prior of eq. 6 (§5.1: 0)', 0.0, 1e6)
    a_hi: float = param(_TP.a_hi, 'upper bound of the source amplitude prior of eq. 6 (§5.1: 80)', 1e-6, 1e6)
    sigma_k: float = param(_TP.sigma_a, 'amplitude noise σ_k of the tracker model, eq. 6 (§5.1: 0.1)', 1e-6, 1e3)
    r_near: float = param(_TP.r_near, 'Fig. 6 DOA model: σ grows below this range (§5.1: 20 m) [m]', 0.0, 1e5)
    r_far: float = param(_TP.r_far, 'Fig. 6 DOA model: σ grows beyond this range (§5.1: 100 m) [m]', 1e-3, 1e5)
    sigma_doa_deg: float = param(_TP.sigma_doa / DEG, 'Fig. 6 DOA σ inside [r_near, r_far] [deg]', 1e-3, 180.0)
    comm_range: float = param(40.0, 'radio range of the §5.1 neighbour rule (else the two nearest) [m]', 1e-3, 1e6)
    selection: str = param('mi', 'next-leader rule: mi (Table 1), nearest or random (baselines)', choices=SELECTIONS)
    prediction: str = param('diffusion', 'belief prediction: diffusion (§2.1), or drift / bank (velocity-aware, '
                            'track_core.idsq.prediction)', choices=PREDICTIONS)
    ack_timeout: float = param(2.0, 'steady-clock wait for an ack before re-selecting [s]', 1e-3, 600.0)
    start: str = param('uniform', 'belief of the start leader at step 0: uniform (§5.1) or election (also its '
                       'radio neighbours\' step-0 amplitude readings; track_core.idsq.leader_protocol)', choices=STARTS)
    reading_timeout: float = param(10.0, 'steady-clock wait for the reading of a step this sensor holds the belief '
                                   'for, then it leads the step predict-only; also the wait for the start election '
                                   '[s]', 1e-3, 3600.0)
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


def sensor_setup(p: SensorParams, position: np.ndarray) -> SensorSetup:
    """The ledger's view of a sensor node's checked parameters ``p``."""
    tp = TrackerParams(v_max=p.v_max, dt=p.dt, a_lo=p.a_lo, a_hi=p.a_hi, sigma_a=p.sigma_k,
                       r_near=p.r_near, r_far=p.r_far, sigma_doa=p.sigma_doa_deg * DEG, prediction=p.prediction)
    return SensorSetup(int(p.id), position, p.type == 'doa', GridSpec.for_field(p.width, p.height, p.cell), tp,
                       p.seed, p.selection, p.ack_timeout, p.start, p.reading_timeout)

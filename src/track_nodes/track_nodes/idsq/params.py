"""Parameters of the IDSQ sensor nodes (``acoustic_sensor``, ``doa_sensor``): §5.1 defaults."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from track_core.idsq import GridSpec, SimNoise, TrackerParams
from track_core.idsq.ledger import SensorSetup
from track_core.idsq.models import DEG
from track_core.idsq.prediction import PREDICTIONS
from track_core.idsq.tracker import SELECTIONS
from track_msgs_py.topics import IDSQ_TRUTH
from track_nodes.base import Param

SENSOR_TYPES = ('acoustic', 'doa')


def sensor_params(sensor_type: str) -> tuple[Param, ...]:
    tp, noise = TrackerParams(), SimNoise()
    return (
        Param('id', 0, 'index of this sensor in the layout published by vehicle_sim', 0, 65535),
        Param('position', [0.0, 0.0], 'sensor position [x, y] in map; must equal its layout entry [m]'),
        Param('type', sensor_type, f'sensor type; this executable runs {sensor_type} sensors', choices=SENSOR_TYPES),
        Param('seed', 0, 'measurement-noise seed (one draw per (seed, sensor id, step))', 0, 2**31 - 1),
        Param('width', 150.0, 'field width (x) covered by the grid (§5.1: 150 m) [m]', 1.0, 1e5),
        Param('height', 250.0, 'field height (y) covered by the grid (§5.1: 250 m) [m]', 1.0, 1e5),
        Param('cell', 5.0, 'grid cell size (§5.1: 5 m) [m]', 0.1, 1e3),
        Param('dt', tp.dt, 'tracker step Δt; the truth of step s is stamped (s + 1)·Δt (§5.1: 0.5 s) [s]', 1e-3, 60.0),
        Param('v_max', tp.v_max, 'maximum vehicle speed of the diffusion disk (§5.1: 15 m/s) [m/s]', 1e-3, 1e3),
        Param('a_lo', tp.a_lo, 'lower bound of the source amplitude prior of eq. 6 (§5.1: 0)', 0.0, 1e6),
        Param('a_hi', tp.a_hi, 'upper bound of the source amplitude prior of eq. 6 (§5.1: 80)', 1e-6, 1e6),
        Param('sigma_k', tp.sigma_a, 'amplitude noise σ_k of the tracker model, eq. 6 (§5.1: 0.1)', 1e-6, 1e3),
        Param('r_near', tp.r_near, 'Fig. 6 DOA model: σ grows below this range (§5.1: 20 m) [m]', 0.0, 1e5),
        Param('r_far', tp.r_far, 'Fig. 6 DOA model: σ grows beyond this range (§5.1: 100 m) [m]', 1e-3, 1e5),
        Param('sigma_doa_deg', tp.sigma_doa / DEG, 'Fig. 6 DOA σ inside [r_near, r_far] [deg]', 1e-3, 180.0),
        Param('amplitude', noise.amplitude, 'simulated source amplitude A (§5.1: 40)', 1e-6, 1e6),
        Param('noise_sigma_a', noise.sigma_a, 'simulated amplitude noise std (§5.1: 0.05)', 0.0, 1e3),
        Param('noise_sigma_doa_deg', noise.sigma_doa / DEG, 'simulated DOA noise std (§5.1: 3°) [deg]', 0.0, 180.0),
        Param('comm_range', 40.0, 'radio range of the §5.1 neighbour rule (else the two nearest) [m]', 1e-3, 1e6),
        Param('selection', 'mi', 'next-leader rule: mi (Table 1), nearest or random (baselines)', choices=SELECTIONS),
        Param('prediction', 'diffusion', 'belief prediction: diffusion (§2.1), or drift / bank (velocity-aware, '
              'track_core.idsq.prediction)', choices=PREDICTIONS),
        Param('ack_timeout', 2.0, 'steady-clock wait for an ack before re-selecting [s]', 1e-3, 600.0),
        Param('track_id', 'idsq_track', 'child_frame_id of the estimate'),
        Param('truth_topics', [IDSQ_TRUTH], 'Odometry truth topics of the sources; each sensor senses the loudest '
              '(nearest) source (track_core.idsq.ledger)'),
    )


def sensor_setup(p: SimpleNamespace, position: np.ndarray, truth_topics: tuple[str, ...]) -> SensorSetup:
    """The ledger's view of a sensor node's checked parameters ``p``."""
    tp = TrackerParams(v_max=p.v_max, dt=p.dt, a_lo=p.a_lo, a_hi=p.a_hi, sigma_a=p.sigma_k,
                       r_near=p.r_near, r_far=p.r_far, sigma_doa=p.sigma_doa_deg * DEG, prediction=p.prediction)
    noise = SimNoise(amplitude=p.amplitude, sigma_a=p.noise_sigma_a, sigma_doa=p.noise_sigma_doa_deg * DEG)
    return SensorSetup(int(p.id), position, p.type == 'doa', GridSpec.for_field(p.width, p.height, p.cell), tp,
                       noise, p.seed, p.selection, truth_topics, p.ack_timeout)

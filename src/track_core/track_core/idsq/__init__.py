"""Leader-based IDSQ tracking in an acoustic-amplitude + DOA sensor field (Liu, Reich, Zhao 2002).

Public API for nodes: ``leader_step`` (Table 1 for one sensor; ``TrackerParams.prediction`` selects the
paper's diffusion or a velocity-aware prediction, ``prediction.py``), ``receive_handoff`` /
``encode_handoff`` / ``validate_handoff`` (the handoff package), ``simulate_measurement``.
"""

from track_core.idsq.config import LeaderConfig
from track_core.idsq.grid import (
    SPARSITY_THRESHOLD,
    Estimate,
    GridSpec,
    SparseBelief,
    diffuse,
    estimate,
    uniform_belief,
)
from track_core.idsq.handoff import (
    HEADER_BYTES,
    Handoff,
    decode_handoff,
    encode_handoff,
    payload_bytes,
    receive_handoff,
    validate_handoff,
)
from track_core.idsq.mi import mutual_information, neighbour_mi
from track_core.idsq.models import SimNoise, TrackerParams, simulate_measurement
from track_core.idsq.network import SensorLayout, start_leader
from track_core.idsq.prediction import PREDICTIONS, Bank, Motion, predict
from track_core.idsq.tracker import LeaderStepResult, centralized_step, leader_step, select_next, update

__all__ = [
    'HEADER_BYTES',
    'PREDICTIONS',
    'SPARSITY_THRESHOLD',
    'Bank',
    'Estimate',
    'GridSpec',
    'Handoff',
    'LeaderConfig',
    'LeaderStepResult',
    'Motion',
    'SensorLayout',
    'SimNoise',
    'SparseBelief',
    'TrackerParams',
    'centralized_step',
    'decode_handoff',
    'diffuse',
    'encode_handoff',
    'estimate',
    'leader_step',
    'mutual_information',
    'neighbour_mi',
    'payload_bytes',
    'predict',
    'receive_handoff',
    'select_next',
    'simulate_measurement',
    'start_leader',
    'uniform_belief',
    'update',
    'validate_handoff',
]

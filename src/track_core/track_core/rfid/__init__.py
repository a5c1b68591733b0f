"""Handheld UHF RFID reader guiding a person to a tag with a particle filter on phase differences
(Raptopoulos, Yioultsis & Dimitriou).

- ``phase``: the phase model (eqs. 3–6, 11): λ from the carrier, wrap period π or 2π, s_θ.
- ``signal``: one MOVE's stream of wrapped reads → unwrapped, smoothed dφ, with outliers and "signal lost".
- ``pf``: the particle filter (eqs. 15–24), vectorised over particles, plus the per-particle loop baseline.
- ``protocol``: ``Command`` (TURN/MOVE/DONE) and ``StepResult``, and the rule that rejects bad results.
- ``guidance``: ``RfidGuidance``: step results in, next command out (the ``rfid_guidance`` node's core).
- ``world``: ``SimReader``: simulated world, user and reader (the ``rfid_reader`` node's core).
- ``search``: one search, start to end.
- ``batch``: the batch least-squares tag fit (the baseline of the filter's tag estimate).
- ``delivery``: the command/response exchange of the node pair, each command exactly once, in order.
"""

from track_core.rfid.batch import BatchFit, fit_tag, path_from_moves, tag_in_user_frame
from track_core.rfid.guidance import GuidanceReply, RfidGuidance
from track_core.rfid.pf import (
    MeasuredMotion,
    PFParams,
    RfidParticleFilter,
    TagEstimate,
    TagMode,
    TagSides,
    UpdateInfo,
    guarded_inverse_square,
    suggested_turn,
)
from track_core.rfid.phase import PhaseModel
from track_core.rfid.protocol import Command, CommandKind, StepResult, step_result_problem
from track_core.rfid.search import SearchOutcome, run_search
from track_core.rfid.signal import (
    DphiEstimate,
    PhaseProcessor,
    PhaseStream,
    StreamStatus,
    UnwrapConfig,
    naive_dphi,
    process_move,
)
from track_core.rfid.world import ReaderOutput, Rect, SimReader, WorldParams, office_obstacles, read_mask

__all__ = [
    'BatchFit',
    'Command',
    'CommandKind',
    'DphiEstimate',
    'GuidanceReply',
    'MeasuredMotion',
    'PFParams',
    'PhaseModel',
    'PhaseProcessor',
    'PhaseStream',
    'ReaderOutput',
    'Rect',
    'RfidGuidance',
    'RfidParticleFilter',
    'SearchOutcome',
    'SimReader',
    'StepResult',
    'StreamStatus',
    'TagEstimate',
    'TagMode',
    'TagSides',
    'UnwrapConfig',
    'UpdateInfo',
    'WorldParams',
    'fit_tag',
    'guarded_inverse_square',
    'naive_dphi',
    'office_obstacles',
    'path_from_moves',
    'process_move',
    'read_mask',
    'run_search',
    'step_result_problem',
    'suggested_turn',
    'tag_in_user_frame',
]

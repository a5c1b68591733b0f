"""One search, start to end: a ``SimReader`` and an ``RfidGuidance`` exchanging commands and results.

This is the loop the ``rfid_reader``/``rfid_guidance`` node pair runs over topics; here it runs in
one process for the experiments. A run succeeds when the user is within ``found_radius`` of the
tag at the end of a MOVE, and fails after ``max_steps`` MOVEs (repeated ones included).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from track_core.rfid.guidance import RfidGuidance
from track_core.rfid.pf import PFParams
from track_core.rfid.protocol import CommandKind
from track_core.rfid.signal import UnwrapConfig
from track_core.rfid.world import SimReader, WorldParams

MAX_STEPS = 200
"""MOVEs (repeated ones included) before a search ends as a failure: the node's and the experiments' default."""


@dataclass(frozen=True)
class SearchOutcome:
    success: bool
    steps: int                 # MOVEs walked (repeated ones included)
    turns: int                 # rotations made (initial search, TURNs, extra directions tried)
    distance_m: float          # walked, including the way back of undone steps
    update_ms: float           # mean wall time of one filter update + suggestion
    repeats: int               # steps undone because their result was unusable
    route: np.ndarray          # (steps + 1, 2) positions after each MOVE
    start_pose: np.ndarray
    final_distance_m: float
    sign_warning: str = ''     # the guidance's convention check (``guidance`` module doc); '' = none


def run_search(world: WorldParams, pf: PFParams, rng: np.random.Generator, max_steps: int = MAX_STEPS,
               start: np.ndarray | None = None, unwrap: UnwrapConfig | None = None) -> SearchOutcome:
    """Run one search with independent streams for the world and the filter drawn from ``rng``.

    ``unwrap``: the reader's signal processing (default: ``UnwrapConfig.for_model(world.phase)``).
    """
    if max_steps < 1:
        raise ValueError(f'max_steps must be >= 1, got {max_steps}')
    r_world, r_pf = (np.random.default_rng(s) for s in rng.bit_generator.seed_seq.spawn(2)) \
        if hasattr(rng.bit_generator, 'seed_seq') else (rng, rng)
    reader = SimReader(world, r_world, start=start, unwrap=unwrap)
    start_pose = reader.pose.copy()
    guide = RfidGuidance(pf, world.phase, r_pf, log_warnings=False)
    cmd = guide.start()
    upd = []
    success = False
    while True:
        out = reader.execute(cmd)
        reply = guide.on_step(out.result)
        if reply.update_s is not None:
            upd.append(reply.update_s)
        if reply.found or out.result.found:
            success = True
            break
        if cmd.kind is CommandKind.MOVE and reader.steps >= max_steps:
            break
        cmd = reply.command
    return SearchOutcome(success, reader.steps, reader.turns, reader.distance,
                         1e3 * float(np.mean(upd)) if upd else float('nan'), reader.repeats,
                         np.array(reader.route), start_pose, reader.distance_to_tag(), guide.sign_warning)

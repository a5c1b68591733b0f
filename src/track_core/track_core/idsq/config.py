"""The one configuration of a sensor's side of the leader protocol, with the §5.1 defaults.

The sensor nodes declare it (``track_nodes.idsq.params``), the offline replay reads it from the
scenario file through the same mapping (``track_nodes.report.network_replay``), and
``simulation.Scenario`` takes its field defaults from it: a replay, an experiment and a live run
start from the same numbers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from track_core.idsq.grid import GridSpec
from track_core.idsq.models import TrackerParams
from track_core.idsq.tracker import SELECTIONS

STARTS = ('uniform', 'election')
"""The start leader's belief at step 0 (``leader_protocol.start_belief``)."""


@dataclass(frozen=True)
class LeaderConfig:
    """Field and grid, radio range, next-leader rule, start belief, the node's timers and the tracker model."""

    width: float = 150.0           # field width (x) the grid covers [m]
    height: float = 250.0          # field height (y) [m]
    cell: float = 5.0              # grid cell size [m]
    comm_range: float = 40.0       # radio range of the §5.1 neighbour rule [m]
    selection: str = 'mi'          # next-leader rule: Table 1's MI, or the nearest / random baselines
    start: str = 'uniform'         # the start leader's belief at step 0
    ack_timeout: float = 2.0       # wait for an ack before re-selecting [s] (the node's steady-clock timer)
    reading_timeout: float = 10.0  # wait for a step's reading, then lead it predict-only [s] (node timer)
    tracker: TrackerParams = field(default_factory=TrackerParams)

    def __post_init__(self) -> None:
        for name in ('width', 'height', 'cell', 'comm_range', 'ack_timeout', 'reading_timeout'):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f'{name}={v!r} must be finite and > 0')
        if self.selection not in SELECTIONS:
            raise ValueError(f'selection={self.selection!r} must be one of {SELECTIONS}')
        if self.start not in STARTS:
            raise ValueError(f'start={self.start!r} must be one of {STARTS}')
        if not isinstance(self.tracker, TrackerParams):
            raise ValueError(f'tracker={self.tracker!r} must be a TrackerParams')
        try:
            self.grid  # noqa: B018 (a field that needs more than 65535 cells a side is refused here)
        except ValueError as exc:
            raise ValueError(f'cell={self.cell!r} is too small for the {self.width} x {self.height} m field: {exc}') \
                from None

    @property
    def grid(self) -> GridSpec:
        """The grid covering the field, origin (0, 0)."""
        return GridSpec.for_field(self.width, self.height, self.cell)

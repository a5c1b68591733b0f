"""The IDSQ simulation and field experiment start from the core's config, as the nodes do."""

from __future__ import annotations

from track_core.idsq.config import LeaderConfig
from track_core.idsq.simulation import Scenario


def test_the_simulation_and_the_field_experiment_start_from_the_config():
    from track_experiments.idsq.field import DT

    c, sc = LeaderConfig(), Scenario()
    assert (sc.width, sc.height, sc.comm_range, sc.grid, sc.tracker) == (c.width, c.height, c.comm_range, c.grid,
                                                                          c.tracker)
    assert c.tracker.dt == DT

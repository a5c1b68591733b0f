"""The rfid scenario file gives the experiments' filter (the node's parameters, read the node's way)."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import yaml

from track_core.rfid.pf import PFParams
from track_core.rfid.search import MAX_STEPS
from track_core.rfid.world import WorldParams
from track_nodes.base.params import all_specs
from track_nodes.rfid.params import pf_config
from track_nodes.rfid.rfid_guidance import RfidGuidanceParams

REPO = Path(__file__).resolve().parents[3]


def _declared(cls, **over) -> SimpleNamespace:
    """The values a node of ``cls`` declares, with ``over`` set."""
    return SimpleNamespace(**({s.name: s.default for s in all_specs(cls)} | over))


def test_the_scenario_file_gives_the_filter_of_the_experiments_table_1():
    """config/rfid.yaml's guidance at N = 100 is Table I's filter (``experiments.table1``: the core's
    defaults with the world's beam) and its search limit the experiments'."""
    from track_experiments.rfid import experiments

    doc = yaml.safe_load((REPO / 'config/rfid.yaml').read_text())
    p = _declared(RfidGuidanceParams, **doc['/**/rfid_guidance']['ros__parameters'])
    assert pf_config(p) == PFParams(n_particles=100, beam_width=WorldParams().beam_width)
    assert p.max_steps == experiments.MAX_STEPS == MAX_STEPS

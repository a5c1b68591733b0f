"""The RFID nodes' core configurations (``PFParams``, ``PhaseModel`` and the guidance's limits): the nodes
declare the core's defaults, and the scenario file gives the filter the experiments run."""

import math
from pathlib import Path
from types import SimpleNamespace

import pytest
from rclpy.parameter import Parameter

from track_core.rfid.guidance import MAX_REPEATS
from track_core.rfid.pf import PFParams
from track_core.rfid.phase import PhaseModel
from track_core.rfid.search import MAX_STEPS
from track_nodes.base import ParameterError
from track_nodes.base.params import all_specs
from track_nodes.rfid.params import pf_config, phase_model
from track_nodes.rfid.rfid_guidance import RfidGuidanceNode, RfidGuidanceParams
from track_nodes.rfid.rfid_reader import RfidReaderParams

REPO = Path(__file__).resolve().parents[4]


def _declared(cls, **over) -> SimpleNamespace:
    """The start values a node of parameter dataclass ``cls`` declares, with ``over`` set."""
    return SimpleNamespace(**{**{s.name: s.default for s in all_specs(cls)}, **over})


def test_the_guidance_declares_the_cores_defaults():
    p = _declared(RfidGuidanceParams)
    assert pf_config(p) == PFParams()
    assert phase_model(p) == PhaseModel()
    assert (p.max_repeats, p.max_steps) == (MAX_REPEATS, MAX_STEPS)


def test_the_simulated_reader_declares_the_same_phase_model():
    assert phase_model(_declared(RfidReaderParams)) == PhaseModel()


def test_the_node_runs_the_filter_its_parameters_give(ros):
    node = ros.add(RfidGuidanceNode(context=ros.context, parameter_overrides=[
        Parameter('n_particles', value=50), Parameter('reinit_factor', value=0.0), Parameter('s_a_deg', value=5.0),
        Parameter('wrap', value='2pi')]))
    assert node.guide.pf.params == PFParams(n_particles=50, reinit_factor=None, s_a=math.radians(5.0))
    assert node.guide.pf.phase == PhaseModel(wrap_period=2.0 * math.pi)
    assert node.guide.max_repeats == MAX_REPEATS and node.loop.max_steps == MAX_STEPS


def test_a_value_the_filter_refuses_is_one_parameter_error_line():
    with pytest.raises(ParameterError) as err:
        pf_config(_declared(RfidGuidanceParams, n_particles=0))
    assert '\n' not in str(err.value) and 'n_particles' in str(err.value)

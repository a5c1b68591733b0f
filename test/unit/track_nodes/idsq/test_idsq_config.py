"""The IDSQ sensors' one configuration (``track_core.idsq.config.LeaderConfig``): the nodes declare its
defaults, and the replay and the experiments build from the same object."""

import dataclasses
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import yaml
from rclpy.parameter import Parameter

from track_core.idsq.config import LeaderConfig
from track_core.idsq.leader_protocol import SensorSetup
from track_core.idsq.models import TrackerParams
from track_nodes.base import ParameterError
from track_nodes.base.params import all_specs
from track_nodes.idsq.params import CONFIG_NAMES, SENSOR_PARAMS, TRACKER_NAMES, leader_config

REPO = Path(__file__).resolve().parents[4]


def _declared(cls) -> SimpleNamespace:
    """The start values a node of parameter dataclass ``cls`` declares."""
    return SimpleNamespace(**{s.name: s.default for s in all_specs(cls)})


@pytest.mark.parametrize('kind', sorted(SENSOR_PARAMS))
def test_the_nodes_declared_defaults_are_the_cores(kind):
    cls = SENSOR_PARAMS[kind]
    assert leader_config(_declared(cls)) == LeaderConfig()
    declared = {s.name for s in all_specs(cls)}
    assert set(CONFIG_NAMES) | set(TRACKER_NAMES) | {'sigma_doa_deg'} <= declared
    # every field of the configuration is a parameter (the tracker's the node does not expose keep the core's)
    assert set(CONFIG_NAMES.values()) == {f.name for f in dataclasses.fields(LeaderConfig)} - {'tracker'}


def test_a_node_builds_its_ledger_from_the_config(ros):
    from track_nodes.idsq.sensor import AcousticSensorNode

    node = ros.add(AcousticSensorNode(context=ros.context, parameter_overrides=[Parameter('comm_range', value=55.0),
                                                                                Parameter('sigma_k', value=0.2)]))
    want = dataclasses.replace(LeaderConfig(), comm_range=55.0, tracker=TrackerParams(sigma_a=0.2))
    assert leader_config(node.p) == want
    assert node.core.s == SensorSetup.of(0, node.position, False, want, 0)


@pytest.mark.parametrize(('over', 'words'), [
    ({'a_lo': 50.0, 'a_hi': 40.0}, ['parameter a_lo=50.0', 'a_hi=40.0']),
    ({'width': 1e5, 'cell': 0.1}, ['parameter cell=0.1', '65535']),
])
def test_a_value_the_core_refuses_is_one_parameter_error_line(ros, over, words):
    from track_nodes.idsq.sensor import AcousticSensorNode

    with pytest.raises(ParameterError) as err:
        AcousticSensorNode(context=ros.context, parameter_overrides=[Parameter(k, value=v) for k, v in over.items()])
    msg = str(err.value)
    assert '\n' not in msg and all(w in msg for w in words), msg


@pytest.mark.parametrize(('kw', 'word'), [({'width': 0.0}, 'width'), ({'selection': 'best'}, 'selection'),
                                          ({'start': 'x'}, 'start'), ({'reading_timeout': float('nan')},
                                                                      'reading_timeout')])
def test_the_core_checks_name_the_field(kw, word):
    with pytest.raises(ValueError, match=f'^{word}='):
        LeaderConfig(**kw)


def test_the_replay_reads_the_config_from_the_scenario_file(tmp_path):
    from track_nodes.report.network_replay import sensors_of

    setup, layout = sensors_of(REPO / 'config/idsq.yaml')  # every tracker setting at the sensors' defaults
    assert (setup.tracker, setup.grid, layout.comm_range) == (LeaderConfig().tracker, LeaderConfig().grid, 40.0)
    doc = yaml.safe_load((REPO / 'config/maritime.yaml').read_text())
    setup, layout = sensors_of(doc)
    sec = doc['/**/sensor_0']['ros__parameters']
    assert (setup.grid.ny, setup.tracker.prediction, setup.start, layout.comm_range) == (
        int(np.ceil(sec['height'] / sec['cell'])), sec['prediction'], sec['start'], sec['comm_range'])
    # a value under /** reaches every sensor, in the replay as in a live run
    doc = yaml.safe_load((REPO / 'config/idsq.yaml').read_text())
    doc['/**']['ros__parameters'].update(width=200.0, r_far=120.0)
    setup, _ = sensors_of(doc)
    assert (setup.grid.nx, setup.tracker.r_far) == (40, 120.0)

"""``report.maritime_sim``: the scenario's sources without ROS, in ``maritime.load``'s layout."""

from __future__ import annotations

import numpy as np
import yaml

from track_nodes.idsq.scenario_files import maritime_yaml
from track_nodes.report import maritime as mar
from track_nodes.report import maritime_sim, network_replay


def test_simulated_sources_feed_the_replay():
    text = maritime_yaml(duration=8.0)
    d = maritime_sim.simulate(text)
    t, truth = d['truth'][mar.NETWORK_TRACK]
    np.testing.assert_array_equal(t, np.arange(1.0, 9.0))
    assert np.all(np.diff(truth[:, 1]) > 3.0)  # the smart target heads north (5-12 m/s)
    _, xs, Ps = d["tracks"][mar.SONAR_TRACK]
    assert xs.shape == (8, 2) and Ps.shape == (8, 2, 2) and np.all(np.linalg.eigvalsh(Ps) > 0)
    assert np.all(np.hypot(*(xs - truth).T) < 30.0)  # the SS-PF starts 14 m off and follows
    tr, xr, _ = d['tracks'][mar.RADAR_DECOY]
    assert tr.size == 8 and np.all(np.hypot(*(xr - d['truth'][mar.RADAR_DECOY][1]).T) < 60.0)
    setup, layout = network_replay.sensors_of(yaml.safe_load(text))
    rows = network_replay.replay(d, setup, layout)
    assert len(rows) == 8
    again = maritime_sim.simulate(text)  # seeded: the same run twice
    np.testing.assert_array_equal(again['tracks'][mar.SONAR_TRACK][1], xs)

"""``maritime.instants``: the per-instant view of ``maritime-seeds`` and its consistent-trackers share."""

import json
import math

import numpy as np
from scipy.optimize import brentq

from track_experiments.cli import experiment_main
from track_experiments.maritime.instants import consistent_share


def test_consistent_share_of_two_equal_circles_matches_the_lens_area():
    """Two consistent tracks with covariance I (2σ circles of radius 2): the exact score is below 0.5 when
    the centres are further apart than the d* at which the lens is half a circle, and the centre distance
    is Rayleigh with σ² = 2, so the share is exp(-d*²/4)."""
    R = 2.0

    def half(d):
        lens = 2 * R**2 * math.acos(d / (2 * R)) - 0.5 * d * math.sqrt(4 * R**2 - d**2)
        return lens / (math.pi * R**2) - 0.5

    d_star = brentq(half, 1e-9, 2 * R - 1e-9)
    want = math.exp(-d_star**2 / 4.0)
    draws = 4000
    got = consistent_share(np.eye(2), np.eye(2), np.random.default_rng(1), draws=draws)
    assert abs(got - want) < 4 * math.sqrt(want * (1 - want) / draws), (got, want)


def test_a_singular_covariance_gives_nan():
    assert math.isnan(consistent_share(np.zeros((2, 2)), np.eye(2), np.random.default_rng(0)))


def test_maritime_seeds_prints_the_per_instant_table(tmp_path, capsys):
    out = tmp_path / 'm.json'
    assert experiment_main(['maritime-seeds', '--quick', '--no-progress', '--set', 'instants=yes',
                            '--json', str(out), '--out', str(tmp_path)]) == 0
    rows = json.loads(out.read_text())['instants']
    assert [r['t'] for r in rows] == sorted(r['t'] for r in rows) and rows[0]['t'] == 0.0 and len(rows) >= 25
    for r in rows:
        assert 1 <= r['runs'] <= 3 and 0.0 <= r['below'] <= 1.0 and 0.0 <= r['below_if_consistent'] <= 1.0
        assert r['nees_sonar'] > 0 and r['nees_network'] > 0
    text = capsys.readouterr().out
    assert 'Per instant over the runs' in text and 'if consistent %' in text
    assert experiment_main(['maritime-seeds', '--quick', '--set', 'instants=maybe']) == 2

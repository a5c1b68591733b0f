"""The seeded synthetic AIS file: reproducible, every preset round-trips, only the planted defects are discarded."""

import numpy as np
import pytest

from track_core.ais import ShipTruth, read_ais
from track_core.ais.reader import PRESETS
from track_core.ais.synthetic import T0, synthetic_ais, write_csv


@pytest.fixture(scope='module')
def small():
    return synthetic_ais(np.random.default_rng(5), n_ships=25, duration=12 * 3600.0, presence=0.5,
                         n_duplicates=6, n_corrupt=3, n_bad=2)


def test_seeded(small):
    again = synthetic_ais(np.random.default_rng(5), n_ships=25, duration=12 * 3600.0, presence=0.5,
                          n_duplicates=6, n_corrupt=3, n_bad=2)
    np.testing.assert_array_equal(small.lat, again.lat)
    np.testing.assert_array_equal(small.t, again.t)


@pytest.mark.parametrize('preset', sorted(PRESETS))
def test_every_preset_round_trips_with_only_the_defects_discarded(tmp_path, small, preset):
    p = write_csv(tmp_path / f'{preset}.csv', small, preset)
    d = read_ais(p)                                                    # the preset is detected from the header
    assert d.derived['columns']['time'] == PRESETS[preset].time
    assert d.skipped == {'malformed row': 0, 'bad time': 2, 'bad MMSI': 0, 'no position': 0, 'bad position': 0,
                         'outside region': 3, 'duplicate': 6, 'implied speed': 0}
    assert d.rows == len(small) and d.t.size == len(small) - 11 and d.warnings == []
    assert d.ships.size == 25
    clean = ~small.bad_time & (np.abs(small.lon - 11.0) < 5.0)          # minus the bad times and corrupt rows
    want = np.unique(small.mmsi[clean] * 10**7 + np.round(small.t[clean] - T0))   # minus the duplicates
    got = d.mmsi * 10**7 + np.round(d.t + d.t0 - T0)
    np.testing.assert_array_equal(np.sort(got), want)


def test_long_intervals_need_the_derived_gap_rule(small, tmp_path):
    d = read_ais(write_csv(tmp_path / 'a.csv', small, 'marinecadastre'))
    derived, fixed = ShipTruth(d).gap_summary(), ShipTruth(d, max_gap=400.0).gap_summary()
    assert 400.0 < derived['median_interval_s'] < 1500.0               # ~12-minute reports
    assert derived['time_known'] > 0.9 and fixed['time_known'] < 0.5

"""AIS reader: bad rows are skipped and counted by reason; the real file's one corrupt position is caught."""

import math

import numpy as np
import pytest

from track_core.ais import read_ais
from track_core.ais.reader import REASONS

GOOD = [
    '2016-01-12 13:02:11.218,235070762,50.7730133333333,-1.092935,157.8,5.9',
    '2016-01-12 13:02:21.218,235070762,50.7725,-1.0925,158.0,5.9',
    '2016-01-12 13:02:12.000,232002939,50.8028616666667,-1.11242333333333,360,102.3',  # COG/SOG n/a: kept
    '1452603753000,232002939,50.8029,-1.1124,,',                                         # epoch ms, empty COG/SOG
]
BAD = {
    'malformed row': ['2016-01-12 13:02:30.000,235070762,50.77,-1.09,157.8',
                      '2016-01-12 13:02:30.000,235070762,50.77,-1.09,157.8,5.9,extra'],
    'bad time': ['2016-13-45 99:00:00.000,235070762,50.77,-1.09,157.8,5.9',
                 ',235070762,50.77,-1.09,157.8,5.9', 'nan,235070762,50.77,-1.09,157.8,5.9'],
    'bad MMSI': ['2016-01-12 13:02:31.000,abc,50.77,-1.09,157.8,5.9', '2016-01-12 13:02:31.000,-5,50.77,-1.09,1,1'],
    'bad position': ['2016-01-12 13:02:32.000,235070762,91,-1.09,157.8,5.9',          # AIS "not available"
                     '2016-01-12 13:02:32.000,235070762,50.77,181,157.8,5.9',
                     '2016-01-12 13:02:32.000,235070762,NaN,-1.09,157.8,5.9',
                     '2016-01-12 13:02:32.000,235070762,50.77,inf,157.8,5.9',
                     '2016-01-12 13:02:32.000,235070762,,-1.09,157.8,5.9',
                     '2016-01-12 13:02:32.000,235070762,north,-1.09,157.8,5.9'],
    'outside region': ['2016-01-12 13:41:20.973,245188000,50.8141,54.83172,87.8,0'],  # the real file's row
    'duplicate': ['2016-01-12 13:02:21.218,235070762,50.7725,-1.0925,158.0,5.9'],
    'implied speed': ['2016-01-12 13:02:26.218,235070762,50.80,-1.0925,158.0,5.9'],  # 3 km in 5 s
}


def test_each_bad_row_is_skipped_and_counted(write_csv):
    rows = GOOD + [r for rs in BAD.values() for r in rs]
    d = read_ais(write_csv(rows))
    assert d.rows == len(rows)
    assert d.t.size == len(GOOD)
    assert d.skipped == {k: len(BAD.get(k, [])) for k in REASONS}
    assert d.n_skipped == len(rows) - len(GOOD)
    text = d.describe()
    assert f'{d.n_skipped} skipped' in text and 'outside region: 1' in text and 'bad position: 6' in text
    assert np.all(np.diff(d.t) >= 0) and d.t[0] == 0.0
    assert d.start_utc == '2016-01-12 13:02:11 UTC'
    k = int(np.flatnonzero(d.mmsi == 232002939)[0])
    assert math.isnan(d.cog[k]) and math.isnan(d.sog[k])                    # "not available" → NaN, row kept
    assert d.t[d.mmsi == 232002939][-1] == pytest.approx(1452603753.0 - d.t0)  # epoch milliseconds


def test_blank_lines_are_not_rows(write_csv):
    d = read_ais(write_csv([GOOD[0], '', '  ,  ', GOOD[1]]))
    assert d.rows == 2 and d.n_skipped == 0


def test_bad_header_and_missing_file(write_csv, tmp_path):
    with pytest.raises(ValueError, match='expected columns'):
        read_ais(write_csv(GOOD, header='a,b,c\n'))
    with pytest.raises(OSError, match='not found'):
        read_ais(tmp_path / 'nope.csv')


def test_real_file(solent):
    """18,623 reports of 91 ships; one corrupt longitude (54.83°) and three duplicated reports."""
    assert solent.rows == 18623
    assert solent.skipped['outside region'] == 1 and solent.skipped['duplicate'] == 3
    assert solent.n_skipped == 4 and solent.t.size == 18619
    assert solent.ships.size == 91
    assert 5000 < solent.t[-1] < 5100
    assert solent.lon.max() < -0.7 and solent.lat.min() > 50.5
    lat0, lon0 = solent.centroid()
    assert 50.7 < lat0 < 50.9 and -1.3 < lon0 < -1.0

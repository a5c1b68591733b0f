"""AIS reader: bad rows are skipped and counted by reason; the real file's one corrupt position is caught."""

import logging
import math
from pathlib import Path

import numpy as np
import pytest

from track_core.ais import read_ais
from track_core.ais.reader import EARTH_R, KNOT, PRESETS, REASONS, ColumnMap, course_speed, region_radius_km

DATA = Path(__file__).parent / 'data'

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
    'no position': ['2016-01-12 13:02:32.000,235070762,91,-1.09,157.8,5.9',           # AIS "not available"
                    '2016-01-12 13:02:32.000,235070762,50.77,181,157.8,5.9',
                    '2016-01-12 13:02:32.000,235070762,,-1.09,157.8,5.9'],              # a message without one
    'bad position': ['2016-01-12 13:02:32.000,235070762,NaN,-1.09,157.8,5.9',
                     '2016-01-12 13:02:32.000,235070762,50.77,inf,157.8,5.9',
                     '2016-01-12 13:02:32.000,235070762,north,-1.09,157.8,5.9',
                     '2016-01-12 13:02:32.000,235070762,95.0,-1.09,157.8,5.9'],
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
    assert d.derived['region_rule'] == 'auto' and d.derived['max_distance_km'] < 5.0     # the good rows' spread
    assert d.n_skipped == len(rows) - len(GOOD)
    text = d.describe()
    assert f'{d.n_skipped} skipped' in text and 'outside region: 1' in text and 'bad position: 4' in text
    assert 'no position: 3' in text
    assert np.all(np.diff(d.t) >= 0) and d.t[0] == 0.0
    assert d.start_utc == '2016-01-12 13:02:11 UTC'
    k = int(np.flatnonzero(d.mmsi == 232002939)[0])
    assert math.isnan(d.cog[k]) and math.isnan(d.sog[k])                    # "not available" → NaN, row kept
    assert d.t[d.mmsi == 232002939][-1] == pytest.approx(1452603753.0 - d.t0)  # epoch milliseconds


def test_blank_lines_are_not_rows(write_csv):
    d = read_ais(write_csv([GOOD[0], '', '  ,  ', GOOD[1]]))
    assert d.rows == 2 and d.n_skipped == 0


def test_bad_header_and_missing_file(write_csv, tmp_path):
    with pytest.raises(ValueError, match='matches no preset'):
        read_ais(write_csv(GOOD, header='a,b,c\n'))
    with pytest.raises(ValueError, match='missing Latitude_degrees'):
        read_ais(write_csv(GOOD, header='Time,MMSI,a,Longitude_degrees,b,c\n'), columns='solent')
    with pytest.raises(OSError, match='not found'):
        read_ais(tmp_path / 'nope.csv')


def test_real_file(solent):
    """18,623 reports of 91 ships; one corrupt longitude (54.83°) and three duplicated reports."""
    assert solent.rows == 18623
    assert solent.skipped['outside region'] == 1 and solent.skipped['duplicate'] == 3      # derived region radius
    assert 33.0 < solent.derived['max_distance_km'] < 34.0 and solent.warnings == []
    assert solent.n_skipped == 4 and solent.t.size == 18619
    assert solent.ships.size == 91
    assert 5000 < solent.t[-1] < 5100
    assert solent.lon.max() < -0.7 and solent.lat.min() > 50.5
    lat0, lon0 = solent.centroid()
    assert 50.7 < lat0 < 50.9 and -1.3 < lon0 < -1.0


# ---- any CSV: column mappings (test/unit/track_core/ais/data/README.md describes the files) ----

FORMATS = [('solent_epoch_ms.csv', None, 'solent'), ('marinecadastre.csv', None, 'marinecadastre'),
           ('dma_no_cog_sog.csv', None, 'dma'),
           ('custom_semicolon.csv', 'time=ts;mmsi=ship;lat=lat;lon=lon;cog=;sog=;time_format=epoch_s;'
            'delimiter=semicolon', None)]
SOG_NORTH = np.radians(0.01) * EARTH_R / 100.0 / KNOT                          # 21.61 kn
SOG_EAST = np.radians(0.02) * EARTH_R * np.cos(np.radians(55.0)) / 120.0 / KNOT  # 20.66 kn


@pytest.mark.parametrize(('name', 'columns', 'preset'), FORMATS)
def test_every_format_variant_reads_the_same_ships(name, columns, preset):
    d = read_ais(DATA / name, columns=columns)
    assert d.rows == 6 and d.n_skipped == 0 and d.warnings == []
    assert d.t0 == 1_700_000_000.0
    if preset is not None:
        assert d.derived['columns'] == {k: getattr(PRESETS[preset], k) for k in d.derived['columns']}
    north, east = d.mmsi == 211000001, d.mmsi == 211000002
    np.testing.assert_allclose(d.t[north], [0.0, 100.0, 200.0])
    np.testing.assert_allclose(d.t[east], [0.0, 120.0, 240.0])
    np.testing.assert_allclose(d.lat[north], [54.0, 54.01, 54.02])            # lat/lon by name, not order
    np.testing.assert_allclose(d.lon[east], [10.0, 10.02, 10.04])
    computed = d.derived['cog_sog'] == 'computed from positions'
    assert computed == (name in ('dma_no_cog_sog.csv', 'custom_semicolon.csv'))
    np.testing.assert_allclose(d.cog[north], 0.0, atol=1e-9)
    np.testing.assert_allclose(d.cog[east], 90.0, atol=0.01 if computed else 0)
    if computed:        # from positions: each report to the next (the last from the previous)
        np.testing.assert_allclose(d.sog[north], SOG_NORTH, rtol=1e-9)
        np.testing.assert_allclose(d.sog[east], SOG_EAST, rtol=1e-9)
    else:               # the file's values
        np.testing.assert_allclose(d.sog[north], 21.6)
        np.testing.assert_allclose(d.sog[east], 20.7)


def test_column_map_text_and_errors():
    m = ColumnMap.parse('time=BaseDateTime; lat=LAT;lon=LON;sog=;time_format=iso')
    assert (m.time, m.lat, m.lon, m.mmsi, m.cog, m.sog, m.time_format) == \
        ('BaseDateTime', 'LAT', 'LON', 'MMSI', 'COG_degrees', None, 'iso')
    assert ColumnMap.parse('dma') is PRESETS['dma'] and ColumnMap.parse('') is None
    assert ColumnMap.parse('delimiter=tab').delimiter == '\t'
    for bad, match in (('colour=red', 'not key=value'), ('lat', 'not key=value'), ('time=', 'cannot be empty'),
                       ('delimiter=ab', 'delimiter')):
        with pytest.raises(ValueError, match=match):
            ColumnMap.parse(bad)


def test_time_formats(write_csv):
    h = 'MMSI,T,LA,LO\n'
    rows = ['211000001,1700000000,54.0,10.0', '211000001,1700000000000,54.0,10.0']  # auto: s, then ms
    d = read_ais(write_csv(rows, header=h), columns='time=T;lat=LA;lon=LO;cog=;sog=')
    assert d.skipped['duplicate'] == 1                          # both are the same instant
    d = read_ais(write_csv(['211000001,1700000000500,54.0,10.0'], header=h),
                 columns='time=T;lat=LA;lon=LO;time_format=epoch_ms')
    assert d.t0 == 1_700_000_000.5
    d = read_ais(write_csv(['211000001,2023-11-14 23:13:20+01:00,54.0,10.0', '211000002,x,54.0,10.0'], header=h),
                 columns='time=T;lat=LA;lon=LO;time_format=iso')
    assert d.t0 == 1_700_000_000.0 and d.skipped['bad time'] == 1   # zone honoured; garbage counted


def test_course_speed_edge_cases():
    cog, sog = course_speed(np.array([0.0]), np.array([1]), np.array([50.0]), np.array([0.0]))
    assert np.isnan(cog).all() and np.isnan(sog).all()               # one report: unknown
    t = np.array([0.0, 0.0, 60.0])
    cog, sog = course_speed(t, np.array([1, 2, 1]), np.array([50.0, 50.0, 50.0]), np.array([179.999, 0.0, -179.999]))
    assert cog[0] == pytest.approx(90.0, abs=1e-3) and cog[2] == cog[0]     # across the antimeridian: east
    assert sog[0] < 5.0 and np.isnan(sog[1])


# ---- the region gate from the data's spread, and loud discards ----

def _port_file(write_csv, n_far: int):
    """60 reports of 12 moored ships in a 20 km harbour, ``n_far`` of 6 ships in a port ~150 km east, one stray."""
    rng = np.random.default_rng(0)
    home = np.c_[54.0 + rng.uniform(-0.1, 0.1, 12), 10.0 + rng.uniform(-0.15, 0.15, 12)]
    port = np.c_[54.0 + rng.uniform(-0.02, 0.02, 6), 12.3 + rng.uniform(-0.03, 0.03, 6)]
    rows = [f'{1700000000 + 60 * k},{211000000 + k % 12},{home[k % 12, 0]:.5f},{home[k % 12, 1]:.5f},,'
            for k in range(60)]
    rows += [f'{1700000000 + 60 * k},{212000000 + k % 6},{port[k % 6, 0]:.5f},{port[k % 6, 1]:.5f},,'
             for k in range(n_far)]
    rows.append('1700000005,213000000,54.0,-170.0,,')                       # a corrupt, valid coordinate
    return write_csv(rows)


def test_derived_region_keeps_a_far_port_and_catches_a_corrupt_row(write_csv, caplog):
    p = _port_file(write_csv, 30)
    with caplog.at_level(logging.WARNING, logger='track_core.ais.reader'):
        d = read_ais(p)
    assert d.skipped['outside region'] == 1 and d.t.size == 90 and d.warnings == [] and not caplog.records
    lat = np.r_[d.lat, 54.0]
    lon = np.r_[d.lon, -170.0]
    assert d.derived['max_distance_km'] == pytest.approx(region_radius_km(lat, lon))
    assert 140.0 < d.derived['max_distance_km'] < 170.0                     # the port is the region's edge
    off = read_ais(p, max_distance_km=None)
    assert off.skipped['outside region'] == 0 and off.derived['max_distance_km'] is None
    assert 'region gate off' in off.describe()


def test_a_rule_dropping_more_than_a_few_percent_warns_with_its_parameter(write_csv, caplog):
    p = _port_file(write_csv, 30)
    with caplog.at_level(logging.WARNING, logger='track_core.ais.reader'):
        d = read_ais(p, max_distance_km=100.0)                               # the former Solent default
    assert d.skipped['outside region'] == 31
    assert len(d.warnings) == 1 and len(caplog.records) == 1
    msg = d.warnings[0]
    assert 'outside region' in msg and '31 of 91 rows' in msg and 'max_distance_km' in msg
    assert caplog.records[0].getMessage() == msg
    quiet = read_ais(p, max_distance_km=100.0, warn_fraction=0.5)
    assert quiet.warnings == []
    with pytest.raises(ValueError, match='max_distance_km'):
        read_ais(p, max_distance_km=-1.0)


def test_a_byte_order_mark_is_not_part_of_the_first_column_name(tmp_path):
    """Exports often start with a UTF-8 BOM: the preset is still detected, and an explicit mapping still finds it."""
    p = tmp_path / 'bom.csv'
    p.write_bytes(('\ufeffID,When,Lat,Lon\n' + '235070762,2016-01-12 13:02:11,50.7730,-1.0929\n'
                   '235070762,2016-01-12 13:02:21,50.7725,-1.0925\n').encode('utf-8'))
    d = read_ais(p, columns='time=When;mmsi=ID;lat=Lat;lon=Lon;cog=;sog=')
    assert d.t.size == 2 and d.mmsi.tolist() == [235070762] * 2 and d.n_skipped == 0
    q = tmp_path / 'bom-solent.csv'
    q.write_bytes(('\ufeff' + 'Time,MMSI,Latitude_degrees,Longitude_degrees,COG_degrees,SOG_knots\n'
                   + GOOD[0] + '\n' + GOOD[1] + '\n').encode('utf-8'))
    assert read_ais(q).t.size == 2  # the solent preset, detected from the header


def test_an_all_messages_export_names_rows_without_a_position(write_csv, caplog):
    """A raw decoded export holds static messages (types 5/24) without a position: counted as such, and the
    warning names that cause, not the column mapping."""
    rows = [f'2016-01-12 13:{m:02d}:00.000,235070762,50.77{m:02d},-1.09,157.8,5.9' for m in range(10, 30)]
    rows += [f'2016-01-12 13:{m:02d}:30.000,235070762,,,,' for m in range(10, 14)]  # 4 of 24: 17 %
    with caplog.at_level(logging.WARNING, logger='track_core.ais.reader'):
        d = read_ais(write_csv(rows))
    assert d.t.size == 20 and d.skipped['no position'] == 4 and d.skipped['bad position'] == 0
    assert len(d.warnings) == 1 and 'rule "no position" dropped 4 of 24 rows' in d.warnings[0]
    assert 'no position' in d.warnings[0] and 'column mapping' not in d.warnings[0]


def test_same_minute_reports_at_other_positions_are_kept_in_track_order(write_csv):
    """Stamps truncated to the minute: one ship's three reports of 13:03 at different positions are kept,
    ordered along the track from its 13:02 report, 20 s apart; the same position again is a duplicate."""
    rows = ['2016-01-12 13:02:00,235070762,50.7700,-1.0900,0,6',
            '2016-01-12 13:03:00,235070762,50.7730,-1.0900,0,6',   # third along the track
            '2016-01-12 13:03:00,235070762,50.7710,-1.0900,0,6',   # first
            '2016-01-12 13:03:00,235070762,50.7720,-1.0900,0,6',   # second
            '2016-01-12 13:03:00,235070762,50.7720,-1.0900,0,6',   # the same report twice
            '2016-01-12 13:04:00,235070762,50.7740,-1.0900,0,6']
    d = read_ais(write_csv(rows))
    assert d.skipped['duplicate'] == 1 and d.t.size == 5 and d.n_skipped == 1
    assert d.t.tolist() == [0.0, 60.0, 80.0, 100.0, 120.0]
    np.testing.assert_allclose(d.lat, [50.77, 50.771, 50.772, 50.773, 50.774])
    assert d.derived['time_refined'] == 2 and d.derived['time_resolution_s'] == 60.0
    assert '2 same-time reports' in d.describe()

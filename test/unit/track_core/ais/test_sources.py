"""Ground truth from AIS and the simulated sources: interpolation, gaps, noise statistics, ids, geometry."""

from dataclasses import replace

import numpy as np
import pytest

from track_core.ais import PATROL, RADAR, LocalTangentPlane, ShipTruth, SourceModel, report_times, simulate_source
from track_core.ais.sources import resolve_site
from track_core.geofeasibility import gaussian_to_ellipse

LAT0, LON0 = 50.8, -1.1


@pytest.fixture
def two_ships(synthetic):
    # ship 1 sails 0.01° east in 100 s (≈ 703 m), then is silent for 1000 s, then one more report;
    # ship 2 is moored 1 km north of ship 1's start
    data = synthetic({111: [(0.0, LAT0, LON0), (100.0, LAT0, LON0 + 0.01), (1100.0, LAT0, LON0 + 0.01)],
                      222: [(0.0, LAT0 + 0.009, LON0), (180.0, LAT0 + 0.009, LON0), (360.0, LAT0 + 0.009, LON0)]})
    return ShipTruth(data, LocalTangentPlane(LAT0, LON0), max_gap=400.0)


def test_truth_interpolates_and_respects_gaps(two_ships):
    tr = two_ships
    p = tr.positions([0.0, 50.0, 100.0, 600.0, 1100.0, 1101.0])
    assert list(tr.mmsi) == [111, 222]
    np.testing.assert_allclose(p[0, 0], [0.0, 0.0], atol=1e-6)
    np.testing.assert_allclose(p[0, 1], 0.5 * p[0, 2], atol=1e-6)         # halfway
    assert 700 < p[0, 2, 0] < 707
    assert np.all(np.isnan(p[0, 3])) and np.all(np.isfinite(p[0, 4]))     # 1000 s gap > max_gap; report itself
    assert np.all(np.isnan(p[0, 5]))                                        # after the last report
    assert np.all(np.isfinite(p[1, :3])) and np.all(np.isnan(p[1, 3:]))    # 180 s gaps are bridged; ends at 360
    assert 995 < p[1, 0, 1] < 1005


def test_report_grid():
    m = SourceModel(period=5.0, offset=4.5)
    np.testing.assert_allclose(report_times(m, 100.0, 120.0), [104.5, 109.5, 114.5, 119.5])
    assert report_times(m, 0.0, 4.0).size == 0


@pytest.mark.parametrize('model', [RADAR, PATROL, replace(RADAR, orientation='fixed', bearing_deg=30.0)])
def test_noise_is_consistent_with_the_reported_ellipse(solent, model):
    """Whitened errors are N(0, I): mean 0, identity covariance, NEES 2, 86.5 % inside the 2σ ellipse."""
    tr = ShipTruth(solent)
    rep = simulate_source(tr, replace(model, dropout=0.0), np.random.default_rng(3), 0.0, 3000.0)
    n = len(rep)
    assert n > 5000
    L = np.linalg.cholesky(rep.R)
    w = np.linalg.solve(L, (rep.mu - rep.truth)[..., None])[..., 0]       # whitened errors
    assert np.all(np.abs(w.mean(0)) < 4 / np.sqrt(n))
    np.testing.assert_allclose(np.cov(w.T), np.eye(2), atol=6 / np.sqrt(n))
    nees = np.sum(w * w, axis=1)
    assert abs(nees.mean() - 2.0) < 6 * 2 / np.sqrt(n)
    inside = np.mean(nees <= 4.0)
    assert abs(inside - (1 - np.exp(-2.0))) < 4 * np.sqrt(0.135 * 0.865 / n)
    _, _, rx, ry, phi = gaussian_to_ellipse(rep.mu, rep.R)                 # 2σ semi-axes of the reports
    np.testing.assert_allclose(rx, 2 * model.sigma_major)
    np.testing.assert_allclose(ry, 2 * model.sigma_minor)
    if model.orientation == 'fixed':
        np.testing.assert_allclose(phi, np.radians(30.0))
    elif model.orientation == 'radial':                                    # major axis ⟂ line of sight
        los = rep.truth - resolve_site(tr, model.site)
        axis = np.stack([np.sin(phi), np.cos(phi)], 1)
        cosang = np.abs(np.sum(axis * los, 1)) / np.linalg.norm(los, axis=1)
        assert np.all(cosang < 1e-9)
    else:                                                                  # uniform bearings
        assert np.histogram(phi, bins=6, range=(0, np.pi))[0].min() > n / 6 * 0.8


def test_rate_dropout_and_local_ids(solent):
    tr = ShipTruth(solent)
    rep = simulate_source(tr, replace(PATROL, dropout=0.25), np.random.default_rng(4), 600.0, 1800.0)
    grid = report_times(PATROL, 600.0, 1800.0)
    assert set(np.unique(rep.t)) <= set(grid) and np.all(np.diff(rep.t) >= 0)
    visible = np.all(np.isfinite(tr.positions(grid)), -1).sum()
    assert abs(len(rep) / visible - 0.75) < 4 * np.sqrt(0.25 * 0.75 / visible)
    assert len(set(rep.ids)) == len(rep.ids) and all(i.startswith('p') and len(i) == 4 for i in rep.ids)
    assert sorted(rep.mmsi.tolist()) == sorted(set(rep.mmsi.tolist()))    # one track per ship
    assert not set(rep.ids) & {str(m) for m in rep.mmsi}                    # ids say nothing of the MMSI
    # local ids are shuffled: the id order is not the MMSI order
    assert list(rep.mmsi) != sorted(rep.mmsi)
    # every report's truth is the ship's interpolated position at that time
    for k in np.random.default_rng(0).choice(len(rep), 50, replace=False):
        s = int(np.flatnonzero(tr.mmsi == rep.mmsi[rep.track[k]])[0])
        np.testing.assert_allclose(tr.positions([rep.t[k]])[s, 0], rep.truth[k])


def test_max_range_and_bad_models(solent):
    tr = ShipTruth(solent)
    m = replace(RADAR, max_range=5000.0, dropout=0.0)
    rep = simulate_source(tr, m, np.random.default_rng(5), 0.0, 600.0)
    assert len(rep) > 0
    assert np.all(np.linalg.norm(rep.truth - resolve_site(tr, m.site), axis=1) <= 5000.0)
    with pytest.raises(ValueError, match='sigma_minor'):
        SourceModel(sigma_major=5.0, sigma_minor=10.0)
    with pytest.raises(ValueError, match='orientation'):
        SourceModel(orientation='sideways')
    with pytest.raises(ValueError, match='dropout'):
        SourceModel(dropout=1.0)
    assert RADAR.scaled(2.0).sigma_major == 30.0 and RADAR.scaled(2.0).sigma_minor == 16.0


def test_same_seed_same_reports(solent):
    tr = ShipTruth(solent)
    a = simulate_source(tr, RADAR, np.random.default_rng(9), 0.0, 300.0)
    b = simulate_source(tr, RADAR, np.random.default_rng(9), 0.0, 300.0)
    np.testing.assert_array_equal(a.mu, b.mu)
    assert a.ids == b.ids


# ---- gap limits from each ship's own report interval ----

def test_gap_limit_is_derived_per_ship(synthetic):
    # ship 1 reports every 10 s, ship 2 every 600 s (a 12-minute-ish reporter), ship 3 once
    reps = {1: [(10.0 * k, LAT0, LON0 + 1e-4 * k) for k in range(30)] + [(700.0, LAT0, LON0)],
            2: [(600.0 * k, LAT0 + 0.01, LON0) for k in range(5)] + [(6100.0, LAT0 + 0.01, LON0)],
            3: [(50.0, LAT0 - 0.01, LON0)]}
    tr = ShipTruth(synthetic(reps), LocalTangentPlane(LAT0, LON0))
    np.testing.assert_allclose(tr.median_interval[:2], [10.0, 600.0])
    assert np.isnan(tr.median_interval[2])
    np.testing.assert_allclose(tr.gap_limit, [200.0, 3600.0, 1900.0])   # 20 × median, capped; ship 3: the median
    p = tr.positions([250.0, 500.0, 1300.0, 4000.0])
    assert np.all(np.isnan(p[0, 1]))             # ship 1: the 410 s gap > 200 s is unknown
    assert np.all(np.isfinite(p[1, :3]))         # ship 2: 600 s gaps bridged
    assert np.all(np.isnan(p[1, 3]))             # ... but not its 3700 s gap (> the 3600 s cap)
    g = tr.gap_summary()
    assert g['rule'].startswith('derived') and g['limit_max_s'] == 3600.0
    fixed = ShipTruth(synthetic(reps), LocalTangentPlane(LAT0, LON0), max_gap=400.0)
    assert np.all(fixed.gap_limit == 400.0) and fixed.gap_summary()['rule'] == 'fixed: 400 s'
    assert np.all(np.isnan(fixed.positions([1000.0])[1]))     # 400 s cannot bridge 600 s reports
    with pytest.raises(ValueError, match='max_gap'):
        ShipTruth(synthetic(reps), max_gap=0.0)


def test_solent_gap_rule_bridges_what_400_s_did(solent):
    """Derived limits bridge at least the gaps the former fixed 400 s bridged (Solent's fast reporters aside)."""
    tr, old = ShipTruth(solent), ShipTruth(solent, max_gap=400.0)
    g, g_old = tr.gap_summary(), old.gap_summary()
    assert g['gaps_bridged'] >= g_old['gaps_bridged'] - 1e-3
    assert g['time_known'] > g_old['time_known']


# ---- sites relative to the data ----

def test_hull_site_is_on_the_edge_of_the_traffic(synthetic):
    from track_core.ais.sources import hull_point

    sq = np.array([[0.0, 0.0], [1000.0, 0.0], [1000.0, 1000.0], [0.0, 1000.0], [500.0, 500.0]])
    np.testing.assert_allclose(hull_point(sq, 90.0), [1000.0, 500.0])        # east edge
    np.testing.assert_allclose(hull_point(sq, 45.0), [1000.0, 1000.0], atol=1e-9)
    np.testing.assert_allclose(hull_point(sq, 180.0), [500.0, 0.0], atol=1e-9)
    line = np.array([[0.0, 0.0], [100.0, 0.0], [200.0, 0.0]])                 # degenerate: no hull
    np.testing.assert_allclose(hull_point(line, 90.0), [200.0, 0.0], atol=1e-9)
    data = synthetic({1: [(0.0, LAT0, LON0), (10.0, LAT0, LON0 + 0.1)], 2: [(0.0, LAT0 + 0.05, LON0)]})
    tr = ShipTruth(data, LocalTangentPlane(LAT0, LON0))
    west = resolve_site(tr, 'hull:270')
    assert west[0] == pytest.approx(0.0, abs=1e-6)                            # the westmost points are at LON0
    np.testing.assert_allclose(resolve_site(tr, None), [0.0, 0.0])
    np.testing.assert_allclose(resolve_site(tr, (LAT0, LON0 + 0.1)), tr.plane.forward(LAT0, LON0 + 0.1))
    for bad in ('hull', 'hull:east', 'coast:90'):
        with pytest.raises(ValueError, match='site'):
            SourceModel(site=bad)


def test_default_radar_site_follows_the_data(solent, synthetic):
    from track_core.ais.sources import CALSHOT

    tr = ShipTruth(solent)
    assert np.linalg.norm(resolve_site(tr, RADAR.site) - tr.plane.forward(*CALSHOT)) < 5000.0   # near Calshot
    far = synthetic({1: [(0.0, 10.0, 100.0), (60.0, 10.0, 100.2)], 2: [(0.0, 10.1, 100.1)]})
    tf = ShipTruth(far)
    assert np.linalg.norm(resolve_site(tf, RADAR.site)) < 30e3                # within the other traffic's extent


def test_a_hull_point_far_from_every_report_moves_to_the_nearest_report():
    """Traffic along two coasts 80 km apart: the hull edge between their ends spans open sea; the radar goes to
    the traffic nearest that point instead. A hull point near traffic stays where it is."""
    from track_core.ais.sources import SITE_SNAP_M, hull_point, traffic_point

    x = np.linspace(0.0, 50e3, 26)
    xy = np.r_[np.c_[x, np.zeros_like(x)], np.c_[x + 30e3, np.full_like(x, 80e3)]]  # two sea lanes
    p = hull_point(xy, 270.0)
    assert np.hypot(*(xy - p).T).min() > SITE_SNAP_M                          # in the empty middle
    q = traffic_point(xy, 270.0)
    assert np.hypot(*(xy - q).T).min() == 0.0 and np.linalg.norm(q - p) == pytest.approx(np.hypot(*(xy - p).T).min())
    sq = np.array([[0.0, 0.0], [1000.0, 0.0], [1000.0, 1000.0], [0.0, 1000.0]])
    np.testing.assert_allclose(traffic_point(sq, 90.0), hull_point(sq, 90.0))


def test_a_continent_wide_file_is_refused_with_the_reason(synthetic):
    """One report per ship across an ocean: no flat projection holds it; the one-line reason names the extent."""
    from track_core.ais.projection import extent_problem

    ships = {i: [(0.0, 10.0 + 4.0 * i, -120.0 + 9.0 * i)] for i in range(1, 12)}
    data = synthetic(ships)
    with pytest.raises(ValueError, match='split the file by region') as err:
        ShipTruth(data)
    assert 'km from the projection origin' in str(err.value) and '\n' not in str(err.value)
    lat0, lon0 = 50.77, -1.09
    assert extent_problem([lat0, lat0 + 2.0], [lon0, lon0], lat0, lon0) is None     # 222 km: one plane holds it
    assert extent_problem([lat0, lat0 + 3.0], [lon0, lon0], lat0, lon0) is not None  # 334 km: > 0.1 % scale error


# ---- simulation in blocks (bounded memory) ----

def test_blocked_simulation_reports_the_same_ships_and_times(solent):
    tr = ShipTruth(solent)
    m = replace(RADAR, dropout=0.0)
    one = simulate_source(tr, m, np.random.default_rng(6), 0.0, 600.0)
    blocks = simulate_source(tr, m, np.random.default_rng(6), 0.0, 600.0, block_cells=len(tr) * 7)  # 7 instants
    o1 = np.lexsort((one.mmsi[one.track], one.t))                          # local ids are shuffled differently
    o2 = np.lexsort((blocks.mmsi[blocks.track], blocks.t))
    np.testing.assert_array_equal(one.t[o1], blocks.t[o2])
    np.testing.assert_array_equal(one.mmsi[one.track][o1], blocks.mmsi[blocks.track][o2])
    np.testing.assert_array_equal(one.truth[o1], blocks.truth[o2])
    np.testing.assert_array_equal(one.R[o1], blocks.R[o2])                  # radial: R depends on geometry only
    w = np.linalg.solve(np.linalg.cholesky(blocks.R), (blocks.mu - blocks.truth)[..., None])[..., 0]
    n = len(blocks)
    assert abs(np.mean(np.sum(w * w, 1)) - 2.0) < 6 * 2 / np.sqrt(n)        # still consistent noise

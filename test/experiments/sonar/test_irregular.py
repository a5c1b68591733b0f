"""``sonar-irregular``: the SS-PF, its UKF peer and a bootstrap reference on the same irregular contacts."""

import json

import numpy as np

from track_experiments.cli import RunConfig
from track_experiments.sonar.irregular import GAP, contact_plan, irregular


def test_the_contact_plan_is_irregular_with_a_gap():
    idx, active = contact_plan(np.random.default_rng(0))
    t = idx * 0.1
    assert np.all(np.diff(t) > 0) and not np.any((t > GAP[0]) & (t < GAP[1]))
    assert np.ptp(np.diff(t[t < GAP[0]])) > 0.5  # not a grid
    assert 0 < active.sum() < active.size


def test_quick_run_gives_every_filter_its_contact_and_gap_steps(tmp_path):
    out = irregular(RunConfig(quick=True, runs=2, out=tmp_path, show_progress=False))
    filters = out.data['filters']
    assert set(filters) == {'pf', 'ukf', 'reference'}
    for row in filters.values():
        assert row['predict_only_per_run'] >= 9 and row['contacts_per_run'] > 15  # the gap is predicted through
        assert 0 < row['rtams_contacts_m'] < 200 and 0 < row['rtams_gap_m'] < 200 and np.isfinite(row['anees_position'])
    # the same model and the same contacts: the PF and its peer are close (a broken filter is far off)
    assert abs(out.data['pf_minus_ukf_rms_m']) < 5.0
    json.dumps(out.data)

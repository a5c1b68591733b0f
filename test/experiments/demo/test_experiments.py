from scipy.stats import chi2

from track_experiments.demo.experiments import run_nees


def test_tracker_is_consistent():
    """Mean ANEES lies in the per-step 99.9 % χ²(4M)/M interval (M = 200 runs).

    Averaging over steps cannot widen the spread, even with correlated steps, so the per-step
    interval bounds the mean conservatively; a filter with a 30 % wrong covariance fails it.
    """
    n_runs = 200
    lo, hi = chi2.ppf([0.0005, 0.9995], 4 * n_runs) / n_runs
    settled = run_nees(n_runs, 100, seed=11)['anees'][10:]
    assert lo < settled.mean() < hi
    overconfident = run_nees(n_runs, 100, seed=11, r=2.0, r_filter=2.0 / 1.3)['anees'][10:]
    assert not lo < overconfident.mean() < hi

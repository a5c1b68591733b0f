import numpy as np
import pytest

from track_core.metrics import match_stamps, mean_nees, rms


def test_match_stamps_pairs_within_tolerance_only():
    it, ie = match_stamps(np.array([0.0, 0.1, 0.2, 0.3]), np.array([0.1, 0.25, 0.3, 5.0]), tol=1e-6)
    assert it.tolist() == [1, 3] and ie.tolist() == [0, 2]


def test_match_stamps_handles_unsorted_and_empty():
    it, ie = match_stamps(np.array([0.3, 0.1]), np.array([0.1, 0.3]))
    assert it.tolist() == [1, 0] and ie.tolist() == [0, 1]
    assert match_stamps(np.array([]), np.array([1.0]))[0].size == 0


def test_rms_and_nees():
    err = np.array([[3.0, 4.0], [0.0, 0.0]])
    assert rms(err) == pytest.approx(np.sqrt(12.5))
    P = np.broadcast_to(np.eye(2) * 25.0, (2, 2, 2))
    assert mean_nees(err, P) == pytest.approx((0.5, 0))


def test_mean_nees_leaves_out_a_singular_covariance_and_counts_it():
    err = np.array([[3.0, 4.0], [1.0, 0.0], [2.0, 0.0]])
    P = np.array([np.eye(2) * 25.0, np.zeros((2, 2)), np.full((2, 2), np.nan)])
    mean, undefined = mean_nees(err, P)  # a collapsed (all-zero) and a non-finite covariance: no LinAlgError
    assert mean == pytest.approx(1.0) and undefined == 2
    assert np.isnan(mean_nees(err[1:], P[1:])[0])

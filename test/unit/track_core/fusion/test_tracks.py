import numpy as np
import pytest

from track_core.fusion import TrackReport, TrackTable


def test_velocity_tracks_are_predicted_and_position_reports_held():
    table = TrackTable(stale_after=1.0, max_prediction=5.0, q_s=0.0)
    table.update('odo', TrackReport(10.0, np.array([0.0, 0.0]), np.eye(2), np.array([2.0, -1.0]), np.eye(2) * 0.5))
    table.update('pose', TrackReport(10.5, np.array([5.0, 5.0]), np.eye(2) * 3))
    ids, mu, R = table.at(11.0)
    assert ids == ['odo', 'pose']
    np.testing.assert_allclose(mu, [[2.0, -1.0], [5.0, 5.0]])
    np.testing.assert_allclose(R[0], np.eye(2) * 1.5)
    np.testing.assert_allclose(R[1], np.eye(2) * 3)


def test_process_noise_grows_the_prediction():
    table = TrackTable(q_s=3.0)
    table.update('a', TrackReport(0.0, np.zeros(2), np.eye(2), np.zeros(2), np.zeros((2, 2))))
    _, _, R = table.at(2.0)
    np.testing.assert_allclose(R[0], np.eye(2) * (1 + 3.0 * 8 / 3))


def test_stale_tracks_drop_out():
    table = TrackTable(stale_after=1.0, max_prediction=5.0)
    table.update('pose', TrackReport(0.0, np.zeros(2), np.eye(2)))
    table.update('odo', TrackReport(0.0, np.zeros(2), np.eye(2), np.zeros(2), np.eye(2)))
    assert table.at(0.9)[0] == ['pose', 'odo']
    assert table.at(1.5)[0] == ['odo']
    assert table.at(6.0)[0] == []


def test_empty_and_bad_parameters():
    assert TrackTable().at(0.0)[1].shape == (0, 2)
    with pytest.raises(ValueError):
        TrackTable(stale_after=0.0)

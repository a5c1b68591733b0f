"""track_arrays: a source's tracks ⇄ TrackArray, and which tracks of an array are usable."""

import numpy as np
import pytest
from rclpy.serialization import deserialize_message, serialize_message

from track_msgs.msg import Track, TrackArray
from track_msgs_py.covariance import NOT_ESTIMATED_VARIANCE
from track_msgs_py.track_arrays import array_to_tracks, position_tracks, track_problems, tracks_to_array
from track_msgs_py.validate import variance_problem


def _tracks(n=5, seed=0):
    rng = np.random.default_rng(seed)
    x = rng.normal(0.0, 100.0, (n, 4))
    A = rng.normal(size=(n, 4, 4))
    return [f't{k}' for k in range(n)], ['radar'] * n, x, A @ np.swapaxes(A, 1, 2) + np.eye(4)


def test_tracks_round_trip_through_a_serialized_array_bit_for_bit():
    ids, src, x, P = _tracks()
    msg = deserialize_message(serialize_message(tracks_to_array(12.25, ids, src, x, P, 'map')), TrackArray)
    t, ids2, src2, x2, P2 = array_to_tracks(msg)
    assert (t, ids2, src2, msg.header.frame_id) == (12.25, ids, src, 'map')
    np.testing.assert_array_equal(x2, x)
    np.testing.assert_array_equal(P2, P)


def test_an_empty_array_reads_as_empty_arrays():
    t, ids, _, x, P = array_to_tracks(tracks_to_array(1.0, [], [], np.zeros((0, 4)), np.zeros((0, 4, 4))))
    assert t == 1.0 and ids == [] and x.shape == (0, 4) and P.shape == (0, 4, 4)


def test_mismatched_lengths_are_refused():
    ids, src, x, P = _tracks()
    with pytest.raises(ValueError, match='5 ids'):
        tracks_to_array(1.0, ids, src[:4], x, P)


def test_position_reports_get_a_velocity_marked_not_estimated():
    x, P = position_tracks(np.array([[1.0, 2.0]]), np.array([[[4.0, 0.5], [0.5, 9.0]]]))
    assert x.tolist() == [[1.0, 0.0, 2.0, 0.0]]
    assert P[0][np.ix_([0, 2], [0, 2])].tolist() == [[4.0, 0.5], [0.5, 9.0]]
    assert P[0, 1, 1] == P[0, 3, 3] == NOT_ESTIMATED_VARIANCE and P[0, 0, 1] == 0.0


def test_a_covariance_of_the_wrong_length_reads_as_nan_and_is_refused():
    msg = TrackArray(tracks=[Track(id='a', covariance=np.eye(4).ravel()), Track(id='b', covariance=[1.0] * 15)])
    _, ids, _, x, P = array_to_tracks(msg)
    assert np.isnan(P[1]).all() and 1 in track_problems(ids, x, P) and 0 not in track_problems(ids, x, P)


def test_each_bad_track_is_named_and_the_others_pass():
    ids, _, x, P = _tracks(8)
    ids[1] = ''
    ids[2] = ids[0]
    x[3, 0] = np.nan
    x[4, 2] = 1e9
    x[5, 1] = 1e5
    P[6, 0, 0] = -5.0
    P[7, 0, 2] += 1.0                        # asymmetric x/y block
    bad = track_problems(ids, x, P)
    assert sorted(bad) == [1, 2, 3, 4, 5, 6, 7]
    assert 'empty id' in bad[1] and 'twice' in bad[2] and 'non-finite' in bad[3]
    assert 'position' in bad[4] and 'velocity' in bad[5] and 'covariance' in bad[6] and 'symmetric' in bad[7]
    assert all('\n' not in r for r in bad.values())


def test_the_batch_variance_test_agrees_with_the_single_report_rule():
    """On a zoo of x/y blocks (tiny, huge, negative, asymmetric, singular), a track is refused for its
    covariance exactly when variance_problem refuses its block."""
    rng = np.random.default_rng(3)
    n = 400
    C = rng.normal(size=(n, 2, 2)) * 10.0 ** rng.integers(-8, 9, (n, 1, 1))
    C[: n // 2] = C[: n // 2] @ np.swapaxes(C[: n // 2], 1, 2)   # half symmetric PSD, half anything
    C[::7] *= 1e-10
    C[::11, 1, 1] = 0.0
    P = np.zeros((n, 4, 4))
    P[:, 0, 0], P[:, 0, 2], P[:, 2, 0], P[:, 2, 2] = C[:, 0, 0], C[:, 0, 1], C[:, 1, 0], C[:, 1, 1]
    P[:, 1, 1] = P[:, 3, 3] = 1.0
    bad = track_problems([f't{k}' for k in range(n)], np.zeros((n, 4)), P)
    single = {k for k in range(n) if variance_problem('c', C[k]) is not None}
    assert set(bad) == single and 0 < len(single) < n

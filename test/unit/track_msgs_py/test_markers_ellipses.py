"""The checked 2σ ellipse points and their LINE_STRIP markers, also through CDR (rclpy.serialization)."""

import numpy as np
import pytest
from rclpy.serialization import deserialize_message, serialize_message
from visualization_msgs.msg import Marker

from track_msgs_py.markers.ellipses import covariance_ellipse_marker, ellipse_points


def cdr(msg):
    """Serialise and deserialise: what a subscriber or a bag reader gets."""
    return deserialize_message(serialize_message(msg), type(msg))


@pytest.mark.parametrize('R', [
    np.array([[4.0, 0.0], [0.0, 1.0]]),
    np.array([[2.0, 1.2], [1.2, 1.0]]),
    np.array([[1e-4, -3e-5], [-3e-5, 2e-4]]),
])
def test_ellipse_marker_points_lie_on_the_two_sigma_contour(R):
    mu = np.array([10.0, -3.0])
    msg = covariance_ellipse_marker(2.0, mu, R, 'map', marker_id=3, n_points=50)
    assert msg.type == Marker.LINE_STRIP and msg.action == Marker.ADD and msg.id == 3
    pts = np.array([[p.x, p.y] for p in cdr(msg).points])
    assert pts.shape == (51, 2)
    np.testing.assert_array_equal(pts[0], pts[-1])  # closed loop
    d = pts - mu
    q = np.einsum('ni,ij,nj->n', d, np.linalg.inv(R), d)
    np.testing.assert_allclose(q, 4.0, rtol=0, atol=1e-9)
    # the points go round the whole ellipse, not one arc
    ang = np.unwrap(np.arctan2(d[:, 1], d[:, 0]))
    assert abs(abs(ang[-1] - ang[0]) - 2 * np.pi) < 1e-9


def test_ellipse_points_scale_with_n_sigma_and_reject_bad_covariance():
    R = np.array([[2.0, 0.5], [0.5, 1.0]])
    np.testing.assert_allclose(ellipse_points(np.zeros(2), R, 3.0), 1.5 * ellipse_points(np.zeros(2), R, 2.0))
    with pytest.raises(ValueError, match='positive semi-definite'):
        ellipse_points(np.zeros(2), np.array([[1.0, 2.0], [2.0, 1.0]]))

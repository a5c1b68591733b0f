"""``markers.tracks.TrackMarkers``: a source's tracks drawn, a 2σ disc and an id label per track, in map."""

import numpy as np
from visualization_msgs.msg import Marker

from track_core.geofeasibility.ellipse import gaussian_to_ellipse
from track_msgs_py.markers.tracks import LABEL_HEIGHT, TrackMarkers
from track_msgs_py.stamps import stamp_to_ns


def test_a_disc_and_a_label_per_track_with_stable_marker_ids():
    mu = np.array([[100.0, -50.0], [0.0, 2000.0]])
    R = np.array([[[400.0, 100.0], [100.0, 100.0]], [[64.0, 0.0], [0.0, 225.0]]])
    build = TrackMarkers('r', lifetime=10.0)
    out = build.build(1796472004.5, ['r017', 'r003'], mu, R).markers
    discs = [m for m in out if m.ns == 'r']
    labels = [m for m in out if m.ns == 'r_ids']
    assert len(discs) == len(labels) == 2 and len(out) == 4
    assert all(m.header.frame_id == 'map' and stamp_to_ns(m.header.stamp) == 1796472004_500000000 for m in out)
    assert [m.type for m in discs] == [Marker.CYLINDER] * 2
    assert [m.type for m in labels] == [Marker.TEXT_VIEW_FACING] * 2
    assert [m.text for m in labels] == ['r017', 'r003'] and [m.id for m in labels] == [m.id for m in discs] == [0, 1]
    _, _, rx, ry, _ = gaussian_to_ellipse(mu, R)
    np.testing.assert_allclose([m.scale.x for m in discs], 2 * rx)   # the 2σ ellipse's axes
    np.testing.assert_allclose([m.scale.y for m in discs], 2 * ry)
    assert [(m.pose.position.x, m.pose.position.y) for m in labels] == [tuple(p) for p in mu.tolist()]
    assert all(m.scale.z == LABEL_HEIGHT and m.lifetime.sec == 10 for m in labels)
    # a later instant: r003 keeps its id, a new track takes the next one
    again = build.build(1796472009.5, ['r099', 'r003'], mu, R).markers
    assert {m.text: m.id for m in again if m.ns == 'r_ids'} == {'r099': 2, 'r003': 1}

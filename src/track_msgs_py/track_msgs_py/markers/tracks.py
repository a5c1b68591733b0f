"""Markers of one source's tracks at one instant (a ``TrackArray``): a 2σ disc and an id label per track.

=========================  ==========================================  ===============================================
data                       message type                                fields
=========================  ==========================================  ===============================================
time ``t``, ids (n,),      visualization_msgs/MarkerArray              per track: a flat ``CYLINDER`` (ns ``<ns>``) of
positions ``mu`` (n, 2),                                               the 2σ ellipse (``markers.fusion.ellipse_discs``)
covariances ``R``                                                      and a ``TEXT_VIEW_FACING`` (ns ``<ns>_ids``,
(n, 2, 2)                                                              ``text`` = the track id) above it; one marker id
                                                                       per track for the whole run, ``lifetime`` each
=========================  ==========================================  ===============================================

This is what makes a topic of many tracks drawable: the ``TrackArray`` itself is a custom type that
no 3D panel draws, and a ``PoseWithCovarianceStamped`` per track shows one track at a time in a
"latest message" display. Every marker is in ``frame_id`` (``map``), so RViz and Foxglove place it.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from builtin_interfaces.msg import Duration
from std_msgs.msg import ColorRGBA, Header
from visualization_msgs.msg import Marker, MarkerArray

from track_msgs_py.markers.fusion import THICKNESS, ellipse_discs
from track_msgs_py.stamps import sec_to_stamp
from track_msgs_py.topics import FRAME_MAP

LABEL_HEIGHT = 20.0  # m: the text height of an id label (a ship's 2σ ellipse is tens of metres)


class TrackMarkers:
    """Builds the MarkerArray of one instant of a source's tracks; remembers each track's marker id."""

    def __init__(self, ns: str, lifetime: float, rgba: Sequence[float] = (0.0, 0.6, 1.0, 0.5),
                 frame_id: str = FRAME_MAP, label_height: float = LABEL_HEIGHT) -> None:
        self.ns, self.lifetime, self.rgba, self.frame_id = ns, lifetime, tuple(rgba), frame_id
        self.label_height = label_height
        self.marker_ids: dict[str, int] = {}

    def build(self, t: float, ids: Sequence[str], mu: np.ndarray, R: np.ndarray) -> MarkerArray:
        """Disc and label of every track of ``ids`` at ``t`` (``mu`` (n, 2), ``R`` (n, 2, 2), already checked)."""
        stamp, life = sec_to_stamp(t), sec_to_stamp(self.lifetime)
        header = Header(stamp=stamp, frame_id=self.frame_id)
        lifetime = Duration(sec=life.sec, nanosec=life.nanosec)
        mids = [self.marker_ids.setdefault(track_id, len(self.marker_ids)) for track_id in ids]
        mu = np.asarray(mu, float).reshape(-1, 2)
        out = MarkerArray()
        out.markers = ellipse_discs(header, mu, R, self.ns, mids, self.rgba, lifetime)
        white = ColorRGBA(r=1.0, g=1.0, b=1.0, a=1.0)
        for mid, track_id, (x, y) in zip(mids, ids, mu.tolist(), strict=True):
            label = Marker(header=header, ns=f'{self.ns}_ids', id=mid, type=Marker.TEXT_VIEW_FACING,
                           action=Marker.ADD, lifetime=lifetime, color=white, text=str(track_id))
            label.pose.position.x, label.pose.position.y = x, y
            label.pose.position.z = THICKNESS + self.label_height
            label.pose.orientation.w = 1.0
            label.scale.z = float(self.label_height)
            out.markers.append(label)
        return out

"""The ``/slam/map`` MarkerArray: landmark means and their 2σ ellipses, the whole map in one message."""

from __future__ import annotations

import numpy as np
from geometry_msgs.msg import Point
from std_msgs.msg import ColorRGBA, Header
from visualization_msgs.msg import Marker, MarkerArray

from track_core.filters import ellipse_points
from track_msgs_py.stamps import sec_to_stamp
from track_msgs_py.topics import FRAME_MAP


def map_markers(t: float, lm: np.ndarray, covs: np.ndarray, frame_id: str = FRAME_MAP,
                n_points: int = 24) -> MarkerArray:
    """The /slam/map message: DELETEALL, the means as one SPHERE_LIST (ns ``slam_landmarks``, id 0) and one
    LINE_STRIP 2σ ellipse per landmark (ns ``slam_ellipses``, id = landmark index), like
    ``ellipses.covariance_ellipse_marker`` but built for the whole map at once (batched ellipses, no
    per-landmark covariance check: the filter's covariances are symmetric positive definite)."""
    header = Header(stamp=sec_to_stamp(t), frame_id=frame_id)
    markers = [Marker(header=header, action=Marker.DELETEALL)]
    means = Marker(header=header, ns='slam_landmarks', id=0, type=Marker.SPHERE_LIST, action=Marker.ADD,
                   color=ColorRGBA(r=0.1, g=0.6, b=0.1, a=1.0))
    means.pose.orientation.w = 1.0
    means.scale.x = means.scale.y = means.scale.z = 0.5
    means.points = [Point(x=x, y=y) for x, y in np.asarray(lm, dtype=float).reshape(-1, 2).tolist()]
    markers.append(means)
    if len(lm):
        pts = ellipse_points(np.asarray(lm, dtype=float), np.asarray(covs, dtype=float), 2.0, n_points)
        color = ColorRGBA(r=0.1, g=0.4, b=1.0, a=1.0)
        for i, loop in enumerate(pts.tolist()):
            m = Marker(header=header, ns='slam_ellipses', id=i, type=Marker.LINE_STRIP, action=Marker.ADD,
                       color=color)
            m.pose.orientation.w = 1.0
            m.scale.x = 0.1
            m.points = [Point(x=x, y=y) for x, y in loop]
            markers.append(m)
    return MarkerArray(markers=markers)

"""Markers of the sonar observer: the 2σ position ellipse of its estimate (ns ``sonar_estimate``, id 0)."""

from __future__ import annotations

import numpy as np
from visualization_msgs.msg import MarkerArray

from track_msgs_py.markers.ellipses import covariance_ellipse_marker
from track_msgs_py.topics import FRAME_MAP

_POS = [0, 2]  # x, y of the CV state [x, vx, y, vy]


def estimate_markers(t: float, mean: np.ndarray, cov: np.ndarray, frame_id: str = FRAME_MAP) -> MarkerArray:
    """The 2σ ellipse of the position part of a CV estimate (mean, cov in [x, vx, y, vy])."""
    mean, cov = np.asarray(mean), np.asarray(cov)
    return MarkerArray(markers=[covariance_ellipse_marker(t, mean[_POS], cov[np.ix_(_POS, _POS)], frame_id,
                                                          ns='sonar_estimate', line_width=1.0)])

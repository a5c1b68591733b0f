"""The n_sigma (default 2σ) ellipse of a position Gaussian as a ``Marker``, for every system's marker builder.

=========================  ==========================================  ===============================================
data                       message type                                fields
=========================  ==========================================  ===============================================
2σ ellipse of (μ, R)       visualization_msgs/Marker (LINE_STRIP)      ``points`` (closed loop), ``scale.x`` = width,
                                                                       ``color``, ``pose`` identity, ``lifetime``
=========================  ==========================================  ===============================================

Each covariance is checked first (``ValueError`` with the reason); the geometry is
``track_core.filters.gaussian.ellipse_points``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from builtin_interfaces.msg import Duration, Time
from geometry_msgs.msg import Point
from std_msgs.msg import ColorRGBA, Header
from visualization_msgs.msg import Marker

from track_core.filters.gaussian import covariance_problem
from track_core.filters.gaussian import ellipse_points as gaussian_ellipse_points
from track_msgs_py.covariance import as_shape
from track_msgs_py.stamps import sec_to_stamp
from track_msgs_py.topics import FRAME_MAP


def ellipse_points(mean: np.ndarray, cov: np.ndarray, n_sigma: float = 2.0, n_points: int = 72) -> np.ndarray:
    """Closed loop (n_points + 1, 2) of the n_sigma ellipse of one outside Gaussian, checked first.

    The geometry is :func:`track_core.filters.gaussian.ellipse_points` (batched; use it directly
    for many ellipses of already-checked covariances); here a bad ``cov`` raises a ``ValueError``
    with its reason.
    """
    mean = as_shape(mean, (2,), 'mean')
    cov = as_shape(cov, (2, 2), 'cov')
    reason = covariance_problem(cov)
    if reason is not None:
        raise ValueError(f'cov: {reason}')
    return gaussian_ellipse_points(mean, cov, n_sigma, n_points)


def covariance_ellipse_marker(t: float, mean: np.ndarray, cov: np.ndarray, frame_id: str = FRAME_MAP, *,
                              ns: str = 'covariance', marker_id: int = 0, n_sigma: float = 2.0,
                              n_points: int = 72, z: float = 0.0, line_width: float = 0.05,
                              color: Sequence[float] = (1.0, 0.5, 0.0, 1.0), lifetime: float = 0.0) -> Marker:
    """LINE_STRIP ``Marker`` of the n_sigma (default 2σ) ellipse of N(mean, cov) in the x/y plane at height z.

    ``lifetime`` 0 keeps the marker until replaced (same ns/id) or deleted.
    """
    mean = as_shape(mean, (2,), 'mean')
    cov = as_shape(cov, (2, 2), 'cov')
    return covariance_ellipse_markers(t, mean[None], cov[None], frame_id, ns=ns, marker_ids=[marker_id],
                                      n_sigma=n_sigma, n_points=n_points, z=z, line_width=line_width, color=color,
                                      lifetime=lifetime)[0]


def covariance_ellipse_markers(t: float, means: np.ndarray, covs: np.ndarray, frame_id: str = FRAME_MAP, *,
                               ns: str = 'covariance', marker_ids: Sequence[int], n_sigma: float = 2.0,
                               n_points: int = 72, z: float = 0.0, line_width: float = 0.05,
                               color: Sequence[float] = (1.0, 0.5, 0.0, 1.0), lifetime: float = 0.0) -> list[Marker]:
    """:func:`covariance_ellipse_marker` of means (n, 2), covs (n, 2, 2): one outline computation for all.

    Each covariance is checked (``ValueError`` naming its row and the reason).
    """
    means = np.asarray(means, dtype=float).reshape(-1, 2)
    covs = np.asarray(covs, dtype=float).reshape(-1, 2, 2)
    for k, cov in enumerate(covs):
        reason = covariance_problem(cov)
        if reason is not None:
            raise ValueError(f'cov{f" {k}" if len(covs) > 1 else ""}: {reason}')
    pts = gaussian_ellipse_points(means, covs, n_sigma, n_points) if len(covs) else np.zeros((0, n_points + 1, 2))
    stamp, life = sec_to_stamp(t), sec_to_stamp(lifetime)
    r, g, b, a = (float(c) for c in color)
    out = []
    for mid, loop in zip(marker_ids, pts.tolist(), strict=True):
        msg = Marker(header=Header(stamp=Time(sec=stamp.sec, nanosec=stamp.nanosec), frame_id=frame_id), ns=ns,
                     id=int(mid), type=Marker.LINE_STRIP, action=Marker.ADD, color=ColorRGBA(r=r, g=g, b=b, a=a),
                     lifetime=Duration(sec=life.sec, nanosec=life.nanosec))
        msg.pose.orientation.w = 1.0
        msg.scale.x = float(line_width)
        msg.points = [Point(x=px, y=py, z=float(z)) for px, py in loop]  # message needs Point objects
        out.append(msg)
    return out

"""The 6×6 covariances of a planar track, as ``Odometry`` and ``PoseWithCovarianceStamped`` carry them.

Row-major, index ``6*i + j``, order x, y, z, rot x, rot y, rot z; the x/y block is entries 0, 1,
6, 7. The entries fall in three classes, with zero off-diagonals outside the estimated block:

* estimated: the x/y block (and yaw for the SLAM pose): the filter's numbers. Fusion and every
  other consumer read the x/y block only (``xy_block``); it is the 2σ ellipse;
* planar, ``PLANAR_VARIANCE`` = 0: z, roll, pitch of the pose and vertical, roll and pitch rates
  of the twist. The world is the map plane (REP-103), so these are fixed at 0, not unknown. 0 is
  the 2-D convention of RViz 2 (``CovarianceVisual`` switches to a flat x/y ellipse plus a yaw
  cone exactly when entries 14, 21 and 28 are ≤ 0), of Foxglove (its covariance sphere is scaled
  by √ of the x, y, z diagonal, so z = 0 draws a flat disc) and of nav2 AMCL's ``amcl_pose``
  (only x, y, yaw filled). robot_localization's ``two_d_mode`` overwrites these entries anyway
  (z/roll/pitch measured 0 with variance 1e-6). 1e6 here would make both viewers draw every
  ellipse as a column 1 km (Foxglove) or 2 km (RViz) tall;
* not estimated, ``NOT_ESTIMATED_VARIANCE`` = 1e6: a quantity of the model that this estimator
  does not estimate: yaw and yaw rate of a CV track, the IDSQ estimate's velocity (x/y twist
  block), the SLAM pose's whole twist (the diff_drive_controller "do not trust" convention). A
  reader recognises it with ``not_estimated(variance)`` (variance ≥ 1e6): fusion holds such a
  track's position instead of predicting it with that velocity. RViz bounds the yaw cone it
  draws, Foxglove ignores orientation, so this value draws nothing huge.

Every entry stays within the input policy's [0, 1e14] (``validate.InputPolicy``: the x/y block
of an estimate in [1e-12, 1e14]; zero x/y blocks only on truth topics, which no node validates
for variance). Validation checks only the x/y blocks.
"""

from __future__ import annotations

import numpy as np

#: Variance of what the planar model fixes (z, roll, pitch; vertical, roll and pitch rates): exactly 0.
PLANAR_VARIANCE = 0.0
#: Variance written for a quantity this estimator does not estimate (yaw of a CV track, the IDSQ velocity).
NOT_ESTIMATED_VARIANCE = 1e6

_PLANAR_IDX = (2, 3, 4)  # z, roll, pitch (pose) or vz, ωx, ωy (twist) of a 6×6 covariance
_YAW = 5
_PLANAR_TEMPLATE = np.zeros((6, 6))
_PLANAR_TEMPLATE[_PLANAR_IDX, _PLANAR_IDX] = PLANAR_VARIANCE


def planar_covariance(C: np.ndarray, yaw_variance: float = NOT_ESTIMATED_VARIANCE) -> np.ndarray:
    """2×2 x/y block → 36 row-major entries: z/roll/pitch ``PLANAR_VARIANCE``, yaw ``yaw_variance``."""
    full = _PLANAR_TEMPLATE.copy()
    full[_YAW, _YAW] = yaw_variance
    full[:2, :2] = C
    return full.reshape(36)


def not_estimated(variance) -> np.ndarray:
    """True where a variance (scalar or array) carries the "not estimated" convention (≥ ``NOT_ESTIMATED_VARIANCE``)."""
    return np.asarray(variance, dtype=float) >= NOT_ESTIMATED_VARIANCE


def xy_block(covariance) -> np.ndarray:
    """The x/y 2×2 block of a 36-entry row-major covariance (a copy, float64)."""
    return np.asarray(covariance, dtype=float).reshape(6, 6)[:2, :2].copy()


def as_shape(a, shape: tuple[int, ...], name: str) -> np.ndarray:
    """``a`` as a float64 array (a state, mean or covariance); ``ValueError`` naming it unless of ``shape``."""
    a = np.asarray(a, dtype=float)
    if a.shape != shape:
        raise ValueError(f'{name} must have shape {shape}, got {a.shape}')
    return a

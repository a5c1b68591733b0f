"""Linear Kalman filter steps (predict, Joseph-form update).

Used directly by the demo tracker and as the linear prediction inside the sonar RB-UKF.
Shapes: x (n,), P (n, n); leading batch dimensions are allowed on x, P and z.
"""

from __future__ import annotations

import numpy as np

from track_core.filters.gaussian import symmetrize


def kf_predict(x: np.ndarray, P: np.ndarray, F: np.ndarray, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """x⁻ = F x, P⁻ = F P Fᵀ + Q."""
    x_pred = np.einsum('ij,...j->...i', F, x)
    P_pred = F @ P @ F.T + Q
    return x_pred, symmetrize(P_pred)


def kf_update(
    x: np.ndarray, P: np.ndarray, z: np.ndarray, H: np.ndarray, R: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Measurement update with z = H x + v, v ~ N(0, R).

    Returns the posterior (x, P), the innovation ν = z − H x and its covariance S.
    The gain comes from a solve with S (never an inverse) and P uses the Joseph form
    (I − K H) P (I − K H)ᵀ + K R Kᵀ, which stays PSD under rounding.
    """
    nu = z - np.einsum('ij,...j->...i', H, x)
    PHt = P @ H.T
    S = symmetrize(H @ PHt + R)
    K = np.swapaxes(np.linalg.solve(S, np.swapaxes(PHt, -1, -2)), -1, -2)
    x_post = x + np.einsum('...ij,...j->...i', K, nu)
    I_KH = np.eye(P.shape[-1]) - K @ H
    P_post = I_KH @ P @ np.swapaxes(I_KH, -1, -2) + K @ R @ np.swapaxes(K, -1, -2)
    return x_post, symmetrize(P_post), nu, S

"""Motion models shared by the systems.

Constant velocity (CV) with state [x, ẋ, y, ẏ], the ordering of the sonar paper's eqs. 1–4:
x_k = F x_{k−1} + w, w ~ N(0, Q), with per-axis blocks
F₁ = [[1, T], [0, 1]] and Q₁ = q_s·[[T³/3, T²/2], [T²/2, T]] (continuous white-noise
acceleration of spectral density q_s).
"""

from __future__ import annotations

import numpy as np


def cv_transition(T: float) -> np.ndarray:
    """4×4 CV transition matrix for sample interval T (s), state [x, ẋ, y, ẏ]."""
    F1 = np.array([[1.0, T], [0.0, 1.0]])
    return np.kron(np.eye(2), F1)


def cv_process_noise(T: float, q_s: float) -> np.ndarray:
    """4×4 CV process-noise covariance for interval T and intensity q_s (m²/s³)."""
    Q1 = q_s * np.array([[T**3 / 3.0, T**2 / 2.0], [T**2 / 2.0, T]])
    return np.kron(np.eye(2), Q1)

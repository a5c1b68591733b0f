"""Shared estimation blocks. A second system that needs one of these imports it from here."""

from track_core.filters.gaussian import (
    CovarianceError,
    check_covariance,
    covariance_problem,
    mahalanobis_sq,
    symmetrize,
)
from track_core.filters.kalman import kf_predict, kf_update
from track_core.filters.motion import cv_process_noise, cv_transition

__all__ = [
    'CovarianceError',
    'check_covariance',
    'covariance_problem',
    'cv_process_noise',
    'cv_transition',
    'kf_predict',
    'kf_update',
    'mahalanobis_sq',
    'symmetrize',
]

"""Shared estimation blocks. A second system that needs one of these imports it from here."""

from track_core.filters.gaussian import (
    CovarianceError,
    check_covariance,
    covariance_problem,
    ellipse_points,
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
    'ellipse_points',
    'kf_predict',
    'kf_update',
    'mahalanobis_sq',
    'symmetrize',
]

# Particle-filter and unscented blocks (added with the sonar system; shared by every system).
from track_core.filters.angles import circular_mean, invert_pose, wrap_angle
from track_core.filters.densities import cholesky_jitter, gaussian_logpdf
from track_core.filters.particles import bimodality_coefficient, liu_west_move, mixture_mean_cov, weighted_mean_cov
from track_core.filters.resampling import (
    effective_sample_size,
    normalize_log_weights,
    systematic_resample,
)
from track_core.filters.unscented import (
    UnscentedWeights,
    sigma_points,
    unscented_predict,
    unscented_update,
    unscented_weights,
)

__all__ += [
    'UnscentedWeights',
    'bimodality_coefficient',
    'cholesky_jitter',
    'circular_mean',
    'effective_sample_size',
    'gaussian_logpdf',
    'invert_pose',
    'liu_west_move',
    'mixture_mean_cov',
    'normalize_log_weights',
    'sigma_points',
    'systematic_resample',
    'unscented_predict',
    'unscented_update',
    'unscented_weights',
    'weighted_mean_cov',
    'wrap_angle',
]

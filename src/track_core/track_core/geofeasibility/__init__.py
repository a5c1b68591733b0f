"""Geofeasibility scores of two 2σ ellipses (paper: ``geofeasibility-scores.txt``).

- :func:`score` — batched scores ``"mc"`` (eq. 55), ``"glr"`` (eq. 71), ``"glr_thresholded"``
  (§3) and ``"exact"`` (eq. 49 in closed form).
- :func:`ellipse_to_gaussian`, :func:`gaussian_to_ellipse` — eqs. 56–59 (φ: bearing of the r_x
  axis, clockwise from north).
- :func:`combine_scores`, :func:`track_score`, :class:`ScoreWindow` — track-level combination;
  :class:`PairWindows` — ScoreWindow for many pairs at once (vectorised); ``FLOOR_2SIGMA`` — the
  floor of a disjoint instant in a combination; :func:`with_prior` — a young window's prior
  (``track`` module docstring).
- :func:`containment` — exact "one contains the other" / "no overlap" tests.
- :func:`candidate_pairs`, :func:`gated_score` — the pairs whose 2σ ellipses may overlap (cKDTree
  radius gate + separating-ellipse test, :mod:`.gate`): scoring only those equals scoring all pairs.
"""

from track_core.geofeasibility.ellipse import ellipse_to_gaussian, gaussian_to_ellipse
from track_core.geofeasibility.gate import candidate_pairs, gated_score
from track_core.geofeasibility.scores import METHODS, score
from track_core.geofeasibility.track import (
    FLOOR_2SIGMA,
    PairWindows,
    ScoreWindow,
    combine_scores,
    common_instants,
    track_score,
    with_prior,
)
from track_core.geofeasibility.validate import check_pairs


def containment(mu1, R1, mu2, R2):
    """(contains, disjoint) boolean arrays for checked-or-not pairs; see :mod:`.overlap`."""
    from track_core.geofeasibility.overlap import containment as _containment

    m1, c1, m2, c2, single = check_pairs(mu1, R1, mu2, R2)
    inside, apart = _containment(m1, c1, m2, c2)
    return (inside.reshape(()), apart.reshape(())) if single else (inside, apart)


__all__ = [
    'FLOOR_2SIGMA',
    'METHODS',
    'PairWindows',
    'ScoreWindow',
    'candidate_pairs',
    'check_pairs',
    'combine_scores',
    'common_instants',
    'containment',
    'ellipse_to_gaussian',
    'gated_score',
    'gaussian_to_ellipse',
    'score',
    'track_score',
    'with_prior',
]

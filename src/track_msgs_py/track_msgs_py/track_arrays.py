"""A source's tracks at one instant ⇄ ``track_msgs/TrackArray``, as numpy arrays.

=========================  ==========================================  ===============================================
data                       message type                                fields
=========================  ==========================================  ===============================================
time ``t``, n tracks:      track_msgs/TrackArray                       ``header.stamp`` ← t, ``header.frame_id``;
ids, sources (n,),                                                     ``tracks[k]``: ``id``, ``source``,
CV states ``x`` (n, 4)                                                 ``x``, ``vx``, ``y``, ``vy`` ← x[k],
``[x, ẋ, y, ẏ]``, ``P``                                                ``covariance`` ← P[k] row-major (16)
(n, 4, 4)
=========================  ==========================================  ===============================================

A source that reports positions only sends its velocity as not estimated (0, with variance
``NOT_ESTIMATED_VARIANCE`` and zero cross terms); ``position_tracks`` builds that. The reader only
extracts numbers (NaNs too); ``track_problems`` says which tracks are usable, all at once, with the
input policy of a single report (finite, bounded position and velocity, an x/y covariance block
inside the variance range, a non-empty id that is unique within the array), so one bad track is
dropped with its reason and the rest of the array is used.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from track_core.filters.gaussian import SYMMETRY_RTOL, symmetrize
from track_msgs.msg import Track, TrackArray
from track_msgs_py.covariance import NOT_ESTIMATED_VARIANCE
from track_msgs_py.stamps import stamp_to_sec, stamped_header
from track_msgs_py.topics import FRAME_MAP
from track_msgs_py.validate import DEFAULT_POLICY, InputPolicy, variance_problem

_POS = [0, 2]  # x, y in [x, ẋ, y, ẏ]
_VEL = [1, 3]


def tracks_to_array(t: float, ids: Sequence[str], sources: Sequence[str], x: np.ndarray, P: np.ndarray,
                    frame_id: str = FRAME_MAP) -> TrackArray:
    """n tracks (ids, sources, states (n, 4), covariances (n, 4, 4)) at ``t`` → one ``TrackArray``."""
    x = np.asarray(x, float).reshape(-1, 4)
    P = np.asarray(P, float).reshape(-1, 16)
    if not len(ids) == len(sources) == x.shape[0] == P.shape[0]:
        raise ValueError(f'tracks_to_array: {len(ids)} ids, {len(sources)} sources, {x.shape[0]} states and '
                         f'{P.shape[0]} covariances')
    msg = TrackArray(header=stamped_header(t, frame_id))
    msg.tracks = [Track(id=i, source=s, x=a, vx=b, y=c, vy=d, covariance=p)
                  for i, s, (a, b, c, d), p in zip(ids, sources, x.tolist(), P, strict=True)]
    return msg


def position_tracks(z: np.ndarray, R: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Position reports (z (n, 2), R (n, 2, 2)) as CV states and covariances with the velocity not estimated."""
    z, R = np.asarray(z, float).reshape(-1, 2), np.asarray(R, float).reshape(-1, 2, 2)
    x = np.zeros((z.shape[0], 4))
    x[:, _POS] = z
    P = np.zeros((z.shape[0], 4, 4))
    P[:, 0, 0], P[:, 0, 2], P[:, 2, 0], P[:, 2, 2] = R[:, 0, 0], R[:, 0, 1], R[:, 1, 0], R[:, 1, 1]
    P[:, 1, 1] = P[:, 3, 3] = NOT_ESTIMATED_VARIANCE
    return x, P


def array_to_tracks(msg: TrackArray) -> tuple[float, list[str], list[str], np.ndarray, np.ndarray]:
    """(t, ids, sources, x (n, 4), P (n, 4, 4)); a covariance that is not 16 numbers reads as NaN."""
    tracks = msg.tracks
    x = np.array([(k.x, k.vx, k.y, k.vy) for k in tracks], float).reshape(-1, 4)
    P = np.full((len(tracks), 16), np.nan)
    for row, k in enumerate(tracks):
        c = np.asarray(k.covariance, float)
        if c.shape == (16,):
            P[row] = c
    return stamp_to_sec(msg.header.stamp), [k.id for k in tracks], [k.source for k in tracks], x, P.reshape(-1, 4, 4)


def track_problems(ids: Sequence[str], x: np.ndarray, P: np.ndarray,
                   policy: InputPolicy = DEFAULT_POLICY) -> dict[int, str]:
    """Index → reason for every unusable track of an array (the others are usable).

    The checks run on all tracks at once; ``variance_problem`` (the rule of a single report, which
    the batch test reproduces) words the reason of a track whose x/y block fails."""
    x, P = np.asarray(x, float).reshape(-1, 4), np.asarray(P, float).reshape(-1, 4, 4)
    C = P[:, _POS][:, :, _POS]
    with np.errstate(invalid='ignore', over='ignore'):
        finite = np.isfinite(x).all(axis=1) & np.isfinite(P).reshape(-1, 16).all(axis=1)
        pos = np.abs(x[:, _POS]).max(axis=1, initial=0.0)
        vel = np.abs(x[:, _VEL]).max(axis=1, initial=0.0)
        scale = np.maximum(np.abs(C).reshape(-1, 4).max(axis=1, initial=0.0), np.finfo(float).tiny)
        symmetric = np.abs(C[:, 0, 1] - C[:, 1, 0]) <= SYMMETRY_RTOL * scale
        eig = np.linalg.eigvalsh(symmetrize(np.where(finite[:, None, None], C, 0.0)))
    variance_ok = (finite & (scale <= policy.variance_ceiling) & symmetric
                   & (eig[:, 0] >= policy.variance_floor) & (eig[:, -1] <= policy.variance_ceiling))
    out: dict[int, str] = {}
    seen: set[str] = set()
    for k, track_id in enumerate(ids):
        if not track_id:
            out[k] = 'tracks: empty id'
        elif track_id in seen:
            out[k] = f'tracks: id {track_id!r} twice in one array'
        seen.add(track_id)
    bad = ~finite | (pos > policy.world_bound) | (vel > policy.speed_bound) | ~variance_ok
    for k in np.flatnonzero(bad).tolist():
        name = f'tracks[{ids[k]}]'
        if k in out:
            continue
        if not finite[k]:
            out[k] = f'{name}: non-finite state or covariance (or not 16 covariance entries)'
        elif pos[k] > policy.world_bound:
            out[k] = f'{name}: position {pos[k]:g} m is beyond the bound ±{policy.world_bound:g}'
        elif vel[k] > policy.speed_bound:
            out[k] = f'{name}: velocity {vel[k]:g} m/s is beyond the bound ±{policy.speed_bound:g}'
        else:
            out[k] = variance_problem(f'{name}.covariance', C[k], policy) or f'{name}.covariance: not a covariance'
    return dict(sorted(out.items()))

"""Victoria Park loader and GPS evaluation.

The data are read at run time from ``victoria_park/`` in the data folder (``track_core.data``).

Files (data README): ``inputs.dat`` (t, encoder speed, steering), ``measurements.dat`` (t, range,
bearing in the eq. 5 convention, tree diameter; equal t = one scan), ``gps.dat`` (t, x, y).

Checked against the data: bearings lie in [0, π] (0 = right, π/2 ahead), measurement rows
with equal t are contiguous (7230 scans, ~0.214 s apart; frames without a detection are absent,
gaps up to 0.86 s), inputs every 25 ms, all files share one time origin; ranges run 1.5–75 m and
diameters 0.02–1.5 m.

Interpretations:
- The laser range hits the trunk surface; the landmark is the trunk centre, so the loader returns
  ``range + diameter / 2`` (``add_radius=True``, the usual ACFR practice).
- Bearings are used unchanged: the data's convention (0 = right, π/2 ahead) *is* eq. 5's.
- GPS evaluation: the GPS frame is a rotated/shifted east–north frame and the SLAM frame starts
  at the origin heading 0, so the estimate (interpolated at the GPS times) is aligned to the GPS
  by one least-squares rigid transform (rotation + translation, no scale; Kabsch/Umeyama).
  GPS jumps are excluded: a fix whose implied speed from the previous kept fix exceeds
  ``max_gps_speed`` (8 m/s; the vehicle is slower) is dropped, as are fixes outside the run.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from track_core.data import data_dir as shared_data_dir


def data_dir() -> Path:
    """``$TRACK_VICTORIA_PARK`` if set, else ``victoria_park`` under :func:`track_core.data.data_root`."""
    env = os.environ.get('TRACK_VICTORIA_PARK')
    return Path(env) if env else shared_data_dir('victoria_park')


@dataclass
class VictoriaPark:
    inputs: np.ndarray        # (K, 3) t, speed, steering
    scan_t: np.ndarray        # (S,) scan times
    scans: list               # S arrays (n, 2): range (to the trunk centre), bearing
    diameters: list           # S arrays (n,)
    gps: np.ndarray           # (G, 3) t, x, y

    @property
    def duration(self) -> float:
        return float(max(self.inputs[-1, 0], self.scan_t[-1]) - min(self.inputs[0, 0], self.scan_t[0]))


def load(path: Path | None = None, *, t_max: float | None = None, add_radius: bool = True) -> VictoriaPark:
    """Read the three files; ``t_max`` keeps only the data up to that time (the ``--quick`` prefix)."""
    p = Path(path) if path is not None else data_dir()
    if not p.is_dir():
        raise OSError(f'Victoria Park data folder not found: {p}')
    inputs = np.loadtxt(p / 'inputs.dat', ndmin=2)
    meas = np.loadtxt(p / 'measurements.dat', ndmin=2)
    gps = np.loadtxt(p / 'gps.dat', ndmin=2)
    if t_max is not None:
        inputs, meas, gps = inputs[inputs[:, 0] <= t_max], meas[meas[:, 0] <= t_max], gps[gps[:, 0] <= t_max]
    t_u, start = np.unique(meas[:, 0], return_index=True)
    r = meas[:, 1] + (0.5 * meas[:, 3] if add_radius else 0.0)
    z = np.stack([r, meas[:, 2]], axis=1)
    scans = np.split(z, start[1:])
    diam = np.split(meas[:, 3], start[1:])
    return VictoriaPark(inputs, t_u, scans, diam, gps)


def events(vp: VictoriaPark) -> Iterator[tuple]:
    """Time-ordered ('input', t, speed, steer) and ('scan', t, z); a scan precedes an input at equal t."""
    ti, ts = vp.inputs[:, 0], vp.scan_t
    order = np.argsort(np.concatenate([ti + 1e-9, ts]), kind='stable')
    k = ti.size
    for j in order:
        if j < k:
            yield ('input', float(ti[j]), float(vp.inputs[j, 1]), float(vp.inputs[j, 2]))
        else:
            yield ('scan', float(ts[j - k]), vp.scans[j - k])


def rigid_align(src: np.ndarray, dst: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares rotation R and translation t with R·src + t ≈ dst (2-D Kabsch)."""
    ms, md = src.mean(0), dst.mean(0)
    U, _, Vt = np.linalg.svd((src - ms).T @ (dst - md))
    d = np.sign(np.linalg.det(Vt.T @ U.T))
    R = Vt.T @ np.diag([1.0, d]) @ U.T
    return R, md - R @ ms


def gps_mask(gps: np.ndarray, max_gps_speed: float = 8.0) -> np.ndarray:
    """Fixes kept for evaluation: implied speed from the previous kept fix ≤ ``max_gps_speed``."""
    keep = np.zeros(gps.shape[0], bool)
    if gps.shape[0] == 0:
        return keep
    keep[0] = True
    last = 0
    for i in range(1, gps.shape[0]):  # sequential by nature (depends on the last kept fix)
        dt = max(gps[i, 0] - gps[last, 0], 1e-3)
        if np.hypot(*(gps[i, 1:] - gps[last, 1:])) / dt <= max_gps_speed:
            keep[i] = True
            last = i
    return keep


def gps_rmse(t_est: np.ndarray, xy_est: np.ndarray, gps: np.ndarray, max_gps_speed: float = 8.0):
    """RMSE [m] of the estimate against GPS after rigid alignment; returns (rmse, aligned xy, kept gps)."""
    g = gps[gps_mask(gps, max_gps_speed)]
    g = g[(g[:, 0] >= t_est[0]) & (g[:, 0] <= t_est[-1])]
    if g.shape[0] < 3:
        raise ValueError(f'gps: {g.shape[0]} usable fixes inside the run, need >= 3')
    est = np.stack([np.interp(g[:, 0], t_est, xy_est[:, 0]), np.interp(g[:, 0], t_est, xy_est[:, 1])], 1)
    R, t = rigid_align(est, g[:, 1:])
    err = est @ R.T + t - g[:, 1:]
    return float(np.sqrt(np.mean(np.sum(err**2, 1)))), (R, t), g


def gps_nees(t_est: np.ndarray, xy_est: np.ndarray, cov_est: np.ndarray, gps: np.ndarray, sigma_gps: float,
             max_gps_speed: float = 8.0) -> np.ndarray:
    """Position NEES (2 degrees of freedom) of the estimate at every GPS fix ``gps_rmse`` keeps.

    The error is the one ``gps_rmse`` scores (estimate interpolated at the fix, after the rigid alignment),
    its covariance R P Rᵀ + σ_gps² I: P the estimate's 2×2 position covariance at the latest estimate at or
    before the fix (``cov_est`` (S, 2, 2) or (S, 3, 3)), R the alignment's rotation, σ_gps the GPS noise per
    axis, which the data set does not give (the receiver "was failing", acfr_info.txt): the caller states it.
    The alignment fits the estimate to the GPS, so the NEES is, if anything, optimistic for the filter.
    """
    _, (R, t), g = gps_rmse(t_est, xy_est, gps, max_gps_speed)
    est = np.stack([np.interp(g[:, 0], t_est, xy_est[:, 0]), np.interp(g[:, 0], t_est, xy_est[:, 1])], 1)
    e = est @ R.T + t - g[:, 1:]
    k = np.clip(np.searchsorted(t_est, g[:, 0], side='right') - 1, 0, len(t_est) - 1)
    S = R @ np.asarray(cov_est)[k][:, :2, :2] @ R.T + sigma_gps ** 2 * np.eye(2)
    return np.einsum('ni,nij,nj->n', e, np.linalg.inv(S), e)


@dataclass
class StandardRun:
    """The run as a robot with standard drivers would give it (``standard_stream``): wheel odometry of
    base_link (the rear-axle centre) at every input, and point-landmark detections in the laser frame."""

    odom_t: np.ndarray          # (K,) stamps of the odometry messages [s] (the input stamps)
    odom_pose: np.ndarray       # (K, 3) base_link in odom (x, y, yaw), odom = the start pose
    twist: np.ndarray           # (K, 2) (v, ω) of base_link from that stamp on
    twist_cov: np.ndarray       # (K, 2, 2) their covariance
    scan_t: np.ndarray          # (S,) scan stamps
    detections: list            # S arrays (n, 3): range to the trunk centre [m], REP-103 bearing [rad], diameter [m]
    laser: tuple[float, float, float]   # the laser in base_link (x ahead, y left, yaw)


def standard_stream(vp: VictoriaPark, vehicle=None, sigma_u: tuple[float, float] = (0.5, np.deg2rad(3.0)),
                    add_radius: bool = False) -> StandardRun:
    """The run as ``nav_msgs/Odometry`` + landmark detections (the converter's content; what a driver of the
    car and a trunk detector would publish).

    Odometry: each input (v_e, α) becomes the twist of the rear-axle centre, (v, ω) = ``acfr_to_unicycle``,
    with covariance J diag(σ_v², σ_α²) Jᵀ (``sigma_u``: the ``victoria_park`` profile's input noise), so a
    unicycle filter fed with it predicts exactly as the ACFR one. The pose is the exact arc of each held
    twist (what a good wheel-odometry driver integrates), vectorised as cumulative sums. Detections:
    ``load``'s range (to the trunk centre when loaded with ``add_radius``), the bearing turned to REP-103
    (eq. 5's − π/2: 0 ahead), the diameter (``add_radius``: ``vp`` holds surface ranges, add d/2). The laser
    is (a, b, 0) in base_link.

    The run's first scan (0.852 s) comes before its first input (0.973 s); the offline filter holds the
    input (0, 0) until then, so the stream starts with the car at rest at the first scan's stamp (twist 0,
    with the covariance of an encoder speed of 0 and steering 0), the same assumption; otherwise the
    unicycle filter would predict that interval with its own yaw-rate noise.
    """
    from track_core.slam.models import VehicleParams, acfr_to_unicycle

    vehicle = vehicle or VehicleParams()
    t, ve, al = vp.inputs[:, 0], vp.inputs[:, 1], vp.inputs[:, 2]
    if vp.scan_t.size and vp.scan_t[0] < t[0]:   # a scan before the first input: the car at rest from the start
        t, ve, al = np.concatenate([vp.scan_t[:1], t]), np.concatenate([[0.0], ve]), np.concatenate([[0.0], al])
    v, w, J = acfr_to_unicycle(ve, al, vehicle)
    cov = J @ np.diag(np.square(sigma_u)) @ np.swapaxes(J, -1, -2)
    cov = 0.5 * (cov + np.swapaxes(cov, -1, -2))                    # exactly symmetric, as a message carries it
    dt = np.diff(t)
    dpsi = w[:-1] * dt
    psi = np.concatenate([[0.0], np.cumsum(dpsi)])
    chord = v[:-1] * dt * np.sinc(dpsi / (2 * np.pi))            # 2 (v/ω) sin(ωΔt/2)
    mid = psi[:-1] + 0.5 * dpsi
    x = np.concatenate([[0.0], np.cumsum(chord * np.cos(mid))])
    y = np.concatenate([[0.0], np.cumsum(chord * np.sin(mid))])
    pose = np.stack([x, y, np.mod(psi + np.pi, 2 * np.pi) - np.pi], axis=1)
    # add_radius: ``vp`` was loaded with raw ranges (add_radius=False); a detection's range is to the centre
    det = [np.stack([z[:, 0] + (0.5 * d if add_radius else 0.0), z[:, 1] - np.pi / 2, d], axis=1)
           for z, d in zip(vp.scans, vp.diameters, strict=True)]
    return StandardRun(t.copy(), pose, np.stack([v, w], axis=1), cov, vp.scan_t.copy(), det,
                       (vehicle.a, vehicle.b, 0.0))

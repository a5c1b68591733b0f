"""ACFR vehicle model and the range–bearing landmark observation of the hybrid SLAM paper.

Vehicle (data README, Masson/Guivant/Nebot §4): state ``(x, y, φ)`` at the laser, inputs
``u = (v_e, α)`` = encoder speed and steering angle. With ``v_c = v_e / (1 − tan α · H/L)``:

    ẋ = v_c cos φ − (v_c/L) tan α (a sin φ + b cos φ)
    ẏ = v_c sin φ + (v_c/L) tan α (a cos φ − b sin φ)
    φ̇ = (v_c/L) tan α

discretised by one explicit Euler step of length ``dt`` (inputs every 25 ms on the real run).
``a = 3.78 m`` (the data README; the original readme's 0.95 m is from the front axle).

Input models (``INPUT_MODELS``), both with F = ∂x⁺/∂x = I + v e₃ᵀ (the CEKF's batched prediction):
``VehicleParams`` (``'acfr'``): the car above, geometry L, H, a, b; ``UnicycleParams``
(``'unicycle'``): u = (v, ω) of ``base_link`` (Odometry's twist, REP-105), the laser a ahead and b
left of it:

    ẋ = v cos φ − ω (a sin φ + b cos φ),  ẏ = v sin φ + ω (a cos φ − b sin φ),  φ̇ = ω

(the ACFR car is this model with v = v_c, ω = (v_c/L) tan α, ``acfr_to_unicycle``). Process noise
is input noise ``σ_u`` (or a 2×2 covariance per input, ``process_noise(..., Su=...)``) through the
input Jacobian, plus an optional additive ``q_pose`` per second (the paper gives no values).

Observation (eq. 5): ``z_r = |m − p|``, ``z_β = atan2(m_y − y, m_x − x) − φ + π/2``: the data set's
bearing convention (0 = vehicle's right, π/2 ahead, π left); bearings and innovations wrapped to
(−π, π] (``filters.wrap_angle``). Vectorised over leading axes (poses ``(..., 3)``, landmarks
``(..., 2)``); ``vehicle_step_scalar`` is the same step in plain floats (the CEKF's hot path).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from track_core.filters import wrap_angle


@dataclass(frozen=True)
class VehicleParams:
    """The ``'acfr'`` input model: ACFR utility-vehicle geometry (metres); inputs (encoder speed, steering)."""

    L: float = 2.83
    H: float = 0.76
    a: float = 3.78
    b: float = 0.50

    def __post_init__(self) -> None:
        if not self.L > 0:
            raise ValueError(f'L = {self.L} m: wheelbase must be > 0')
        if not 0 <= self.H < self.L:
            raise ValueError(f'H = {self.H} m: must be in [0, L)')


@dataclass(frozen=True)
class UnicycleParams:
    """Unicycle / differential-drive robot (module docstring): inputs (v [m/s], ω [rad/s]) of base_link;
    the laser (the state's position) ``a`` ahead and ``b`` left of base_link [m]."""

    a: float = 0.0
    b: float = 0.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.a) and math.isfinite(self.b)):
            raise ValueError(f'laser offset ({self.a}, {self.b}) m: must be finite')


#: input model name -> its parameter class (the ``slam`` node's ``input_model``)
INPUT_MODELS = {'acfr': VehicleParams, 'unicycle': UnicycleParams}
InputModel = VehicleParams | UnicycleParams


def acfr_to_unicycle(ve, alpha, vp: VehicleParams = VehicleParams()):
    """ACFR inputs (encoder speed, steering) → (v, ω) of the rear-axle centre and ∂(v, ω)/∂(v_e, α) (..., 2, 2).

    v = v_e / (1 − tan α · H/L), ω = v tan α / L (the data README's model, module docstring): the
    twist a wheel-odometry driver of the car would publish for base_link at the rear-axle centre.
    Σ_(v,ω) = J Σ_(v_e,α) Jᵀ then gives the ACFR filter's process noise exactly (chain rule).
    """
    ve, alpha = np.asarray(ve, dtype=float), np.asarray(alpha, dtype=float)
    t = np.tan(alpha)
    den = 1.0 - t * vp.H / vp.L
    v = ve / den
    w = v * t / vp.L
    t_al = 1.0 + t * t
    v_ve, v_al = 1.0 / den, ve * (vp.H / vp.L) * t_al / den**2
    J = np.stack([np.stack([v_ve, v_al], -1), np.stack([v_ve * t / vp.L, (v_al * t + v * t_al) / vp.L], -1)], -2)
    return v, w, J


def _unicycle_rates(pose: np.ndarray, u: np.ndarray, vp: UnicycleParams):
    phi = pose[..., 2]
    v, w = u[..., 0], u[..., 1]
    c, s = np.cos(phi), np.sin(phi)
    ax = vp.a * s + vp.b * c
    ay = vp.a * c - vp.b * s
    f = np.stack([v * c - w * ax, v * s + w * ay, w + 0.0 * c], axis=-1)
    f_phi = np.stack([-v * s - w * ay, v * c - w * ax, np.zeros_like(ax)], axis=-1)
    one = np.ones_like(ax)
    f_u = np.stack([np.stack([c, -ax], -1), np.stack([s, ay], -1), np.stack([0.0 * one, one], -1)], axis=-2)
    return f, f_phi, f_u


def _rates(pose: np.ndarray, u: np.ndarray, vp: InputModel):
    """Continuous-time rates f, ∂f/∂φ and ∂f/∂u (last axes (3,), (3,), (3, 2))."""
    pose = np.asarray(pose, dtype=float)
    u = np.asarray(u, dtype=float)
    if isinstance(vp, UnicycleParams):
        return _unicycle_rates(pose, u, vp)
    phi = pose[..., 2]
    ve, al = u[..., 0], u[..., 1]
    t = np.tan(al)
    den = 1.0 - t * vp.H / vp.L
    vc = ve / den
    k = vc * t / vp.L
    c, s = np.cos(phi), np.sin(phi)
    ax = vp.a * s + vp.b * c
    ay = vp.a * c - vp.b * s
    f = np.stack([vc * c - k * ax, vc * s + k * ay, k], axis=-1)
    f_phi = np.stack([-vc * s - k * ay, vc * c - k * ax, np.zeros_like(k)], axis=-1)
    vc_ve = 1.0 / den
    k_ve = vc_ve * t / vp.L
    t_al = 1.0 + t * t
    vc_al = ve * (vp.H / vp.L) * t_al / den**2
    k_al = (vc_al * t + vc * t_al) / vp.L
    f_u = np.stack([
        np.stack([vc_ve * c - k_ve * ax, vc_al * c - k_al * ax], axis=-1),
        np.stack([vc_ve * s + k_ve * ay, vc_al * s + k_al * ay], axis=-1),
        np.stack([k_ve, k_al], axis=-1),
    ], axis=-2)
    return f, f_phi, f_u


def vehicle_step(pose: np.ndarray, u: np.ndarray, dt: float, vp: InputModel = VehicleParams()) -> np.ndarray:
    """One Euler step of the input model ``vp`` (ACFR or unicycle); heading wrapped to (−π, π]."""
    f, _, _ = _rates(pose, u, vp)
    out = np.asarray(pose, dtype=float) + dt * f
    out[..., 2] = wrap_angle(out[..., 2])
    return out


def vehicle_jacobians(pose: np.ndarray, u: np.ndarray, dt: float,
                      vp: InputModel = VehicleParams()) -> tuple[np.ndarray, np.ndarray]:
    """``F = ∂x⁺/∂x`` (..., 3, 3) and ``G = ∂x⁺/∂u`` (..., 3, 2) of ``vehicle_step``."""
    _, f_phi, f_u = _rates(pose, u, vp)
    F = np.broadcast_to(np.eye(3), (*f_phi.shape[:-1], 3, 3)).copy()
    F[..., :, 2] += dt * f_phi
    return F, dt * f_u


def vehicle_step_scalar(x: float, y: float, phi: float, ve: float, al: float, dt: float,
                        vp: InputModel) -> tuple[float, ...]:
    """``vehicle_step`` + ``vehicle_jacobians`` for one pose in plain floats (the per-input hot path).

    Returns ``(x⁺, y⁺, φ⁺, F02, F12, G00, G01, G10, G11, G20, G21)``: the Euler step (heading
    wrapped to (−π, π]), the two non-trivial entries of F = ∂x⁺/∂x (F = I except F[0,2], F[1,2])
    and G = ∂x⁺/∂u row by row. Same arithmetic as the array version (tested against it); about
    20× faster than numpy for a single 3-vector, which matters at 40 inputs per second.
    With ``UnicycleParams`` the inputs are (v, ω) (module docstring): ``ve`` = v, ``al`` = ω.
    """
    if isinstance(vp, UnicycleParams):
        return _unicycle_step_scalar(x, y, phi, ve, al, dt, vp)
    t = math.tan(al)
    hl = vp.H / vp.L
    den = 1.0 - t * hl
    vc = ve / den
    k = vc * t / vp.L
    c, s = math.cos(phi), math.sin(phi)
    ax = vp.a * s + vp.b * c
    ay = vp.a * c - vp.b * s
    fx, fy = vc * c - k * ax, vc * s + k * ay
    vc_ve = 1.0 / den
    k_ve = vc_ve * t / vp.L
    t_al = 1.0 + t * t
    vc_al = ve * hl * t_al / (den * den)
    k_al = (vc_al * t + vc * t_al) / vp.L
    ph = phi + dt * k
    if not -math.pi < ph <= math.pi:
        ph = math.pi - (math.pi - ph) % (2.0 * math.pi)  # = wrap_angle (Python % ≡ np.mod)
    return (x + dt * fx, y + dt * fy, ph,
            dt * (-vc * s - k * ay), dt * (vc * c - k * ax),
            dt * (vc_ve * c - k_ve * ax), dt * (vc_al * c - k_al * ax),
            dt * (vc_ve * s + k_ve * ay), dt * (vc_al * s + k_al * ay),
            dt * k_ve, dt * k_al)


def _unicycle_step_scalar(x: float, y: float, phi: float, v: float, w: float, dt: float,
                         vp: UnicycleParams) -> tuple[float, ...]:
    """``vehicle_step_scalar`` for the unicycle model (same return layout)."""
    c, s = math.cos(phi), math.sin(phi)
    ax = vp.a * s + vp.b * c
    ay = vp.a * c - vp.b * s
    ph = phi + dt * w
    if not -math.pi < ph <= math.pi:
        ph = math.pi - (math.pi - ph) % (2.0 * math.pi)
    return (x + dt * (v * c - w * ax), y + dt * (v * s + w * ay), ph,
            dt * (-v * s - w * ay), dt * (v * c - w * ax),
            dt * c, -dt * ax, dt * s, dt * ay, 0.0, dt)


def process_noise(pose: np.ndarray, u: np.ndarray, dt: float, sigma_u: tuple[float, float],
                  q_pose: tuple[float, float, float] = (0.0, 0.0, 0.0),
                  vp: InputModel = VehicleParams(), Su: np.ndarray | None = None) -> np.ndarray:
    """Q = G Σ_u Gᵀ + dt·diag(q_pose) for one step (3×3 for a single pose); Σ_u = ``Su`` (2×2) when given,
    else diag(σ_u²)."""
    _, G = vehicle_jacobians(pose, u, dt, vp)
    Su = np.diag(np.square(sigma_u)) if Su is None else np.asarray(Su, dtype=float)
    return G @ Su @ np.swapaxes(G, -1, -2) + dt * np.diag(q_pose)


def observe(pose: np.ndarray, m: np.ndarray) -> np.ndarray:
    """Eq. 5 without noise: (range, bearing) of landmarks ``m`` seen from ``pose``; broadcasts."""
    pose = np.asarray(pose, dtype=float)
    m = np.asarray(m, dtype=float)
    dx = m[..., 0] - pose[..., 0]
    dy = m[..., 1] - pose[..., 1]
    r = np.hypot(dx, dy)
    b = wrap_angle(np.arctan2(dy, dx) - pose[..., 2] + np.pi / 2)
    return np.stack(np.broadcast_arrays(r, b), axis=-1)


def observe_jacobians(pose: np.ndarray, m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``∂h/∂pose`` (..., 2, 3) and ``∂h/∂m`` (..., 2, 2) of eq. 5."""
    pose = np.asarray(pose, dtype=float)
    m = np.asarray(m, dtype=float)
    dx = m[..., 0] - pose[..., 0]
    dy = m[..., 1] - pose[..., 1]
    dx, dy = np.broadcast_arrays(dx, dy)
    q = dx * dx + dy * dy
    r = np.sqrt(q)
    Hm = np.stack([np.stack([dx / r, dy / r], -1), np.stack([-dy / q, dx / q], -1)], -2)
    Hv = np.concatenate([-Hm, np.stack([np.zeros_like(r), -np.ones_like(r)], -1)[..., None]], axis=-1)
    return Hv, Hm


def inverse_observe(pose: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Landmark position from a pose and a (range, bearing) observation (inverse of eq. 5)."""
    pose = np.asarray(pose, dtype=float)
    z = np.asarray(z, dtype=float)
    th = pose[..., 2] + z[..., 1] - np.pi / 2
    return np.stack([pose[..., 0] + z[..., 0] * np.cos(th), pose[..., 1] + z[..., 0] * np.sin(th)], axis=-1)


def inverse_observe_jacobians(pose: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``∂m/∂pose`` (..., 2, 3) and ``∂m/∂z`` (..., 2, 2) of ``inverse_observe``."""
    pose = np.asarray(pose, dtype=float)
    z = np.asarray(z, dtype=float)
    th = pose[..., 2] + z[..., 1] - np.pi / 2
    r = z[..., 0]
    c, s = np.cos(th), np.sin(th)
    one, zero = np.ones_like(c), np.zeros_like(c)
    Gv = np.stack([np.stack([one, zero, -r * s], -1), np.stack([zero, one, r * c], -1)], -2)
    Gz = np.stack([np.stack([c, -r * s], -1), np.stack([s, r * c], -1)], -2)
    return Gv, Gz

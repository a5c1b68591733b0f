"""Named settings of the hybrid SLAM: the filter parameters of the real Victoria Park run and of the
Fig. 1 loop world, shared by the ``slam`` node's ``profile`` parameter and the experiments.

``victoria_park`` (chosen from the sensor and vehicle description, not fitted to the GPS):
- noise: encoder speed 0.5 m/s, steering 3°, range 0.5 m, bearing 1° (σ);
- ``max_range`` 30 m: detections farther away (the laser reports trunks up to 75 m) are ignored,
  so that every landmark association may use is watched by the failure detector (see
  ``association.py``); landmarks are also only started within 30 m;
- ``min_obs`` = 3: a new trunk is mapped after three sightings (tentative features, see
  ``cekf.py``), which keeps one-off returns (people, posts, clutter) out of the map;
- ``min_separation`` 3 m: trunks closer than that (clumps, forked trees) do not count as
  separate landmarks for the failure detector;
- CEKF local area: radius 60 m, global update every 20 m.

``loop_sim``: the noise of the default ``LoopWorld`` and the ambiguity trigger on (the world is
designed for it); the pose starts at the world's start.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from track_core.slam.cekf import SlamParams
from track_core.slam.hybrid import HybridParams
from track_core.slam.pf import PFParams
from track_core.slam.sim import LoopWorld


@dataclass(frozen=True)
class SlamProfile:
    """The three configuration groups of ``HybridSlam``, the initial laser pose [x, y, heading] and its
    variances [m², m², rad²] (the node's ``pose0``, ``pose0_var``; the experiments' start)."""

    slam: SlamParams
    pf: PFParams
    hybrid: HybridParams
    pose0: tuple[float, float, float]
    pose0_var: tuple[float, float, float] = (1e-6, 1e-6, 1e-6)

    def __post_init__(self) -> None:
        for name, kind in (('slam', SlamParams), ('pf', PFParams), ('hybrid', HybridParams)):
            if not isinstance(getattr(self, name), kind):
                raise ValueError(f'{name}={getattr(self, name)!r} must be a {kind.__name__}')
        if len(self.pose0) != 3 or not np.all(np.isfinite(self.pose0)):
            raise ValueError(f'pose0={self.pose0!r} must be 3 finite numbers')
        var = np.asarray(self.pose0_var, dtype=float)
        if var.shape != (3,) or not np.all(np.isfinite(var) & (var > 0)):
            raise ValueError(f'pose0_var={self.pose0_var!r} must be 3 finite numbers > 0')

    def prior(self) -> tuple[np.ndarray, np.ndarray]:
        """The filter's start: (pose0, diag(pose0_var))."""
        return np.array(self.pose0, dtype=float), np.diag(np.asarray(self.pose0_var, dtype=float))


VICTORIA_PARK = SlamProfile(
    slam=SlamParams(sigma_v=0.5, sigma_steer=np.deg2rad(3.0), sigma_r=0.5, sigma_b=np.deg2rad(1.0),
                    max_range=30.0, init_max_range=30.0, local_radius=60.0, local_exit=20.0, min_separation=3.0,
                    min_obs=3),
    pf=PFParams(sigma_r=0.5, sigma_b=np.deg2rad(1.0)),
    hybrid=HybridParams(),
    pose0=(0.0, 0.0, 0.0))


def loop_sim_params(w: LoopWorld) -> tuple[SlamParams, PFParams]:
    """CEKF and PF settings with the noise of the loop world ``w``."""
    sp = SlamParams(sigma_v=w.sigma_v, sigma_steer=w.sigma_steer, sigma_r=w.sigma_r, sigma_b=w.sigma_b,
                    max_range=w.max_range, init_max_range=w.max_range, local_radius=60.0, local_exit=20.0)
    pp = PFParams(sigma_v=w.sigma_v, sigma_steer=w.sigma_steer, sigma_r=w.sigma_r, sigma_b=w.sigma_b)
    return sp, pp


def loop_sim(w: LoopWorld | None = None) -> SlamProfile:
    """The profile of the loop world ``w`` (default ``LoopWorld()``, the node's ``loop_sim``)."""
    w = LoopWorld() if w is None else w
    sp, pp = loop_sim_params(w)
    return SlamProfile(slam=sp, pf=pp, hybrid=HybridParams(trigger_on_ambiguity=True),
                       pose0=tuple(float(v) for v in w.start()))


#: A unicycle / differential-drive robot with a 360° laser and wheel odometry (the ``slam`` node with
#: ``input_model: odometry``): inputs (v, ω) with σ 0.1 m/s and 0.05 rad/s when the odometry carries no
#: twist covariance, laser range 0.1 m and bearing 1° (an extracted pole's centre, not one beam),
#: bearings all round ((−π, π), eq. 5 convention), trunks/poles mapped after 3 sightings. A starting
#: point for a new robot, not fitted to any data set.
GENERIC = SlamProfile(
    slam=SlamParams(sigma_v=0.1, sigma_steer=0.05, sigma_r=0.1, sigma_b=np.deg2rad(1.0), max_range=30.0,
                    init_max_range=30.0, local_radius=60.0, local_exit=20.0, min_separation=1.0, min_obs=3),
    pf=PFParams(sigma_v=0.1, sigma_steer=0.05, sigma_r=0.1, sigma_b=np.deg2rad(1.0)),
    hybrid=HybridParams(bearing_limits=(-np.pi, np.pi)),
    pose0=(0.0, 0.0, 0.0))

#: profile name -> a function returning it (the node's ``profile`` parameter)
PROFILES = {'victoria_park': lambda: VICTORIA_PARK, 'loop_sim': loop_sim, 'generic': lambda: GENERIC}

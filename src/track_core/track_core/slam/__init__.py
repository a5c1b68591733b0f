"""Hybrid SLAM: Compressed EKF that switches to particle-filter localisation (Masson, Guivant & Nebot).

- ``models``: the ACFR and unicycle input models (state at the laser) and eq. 5 range–bearing observation.
- ``odometry``: wheel odometry (nav_msgs/Odometry) → unicycle inputs, the odom track and map → odom.
- ``landmarks``: point-landmark extraction (trunks, poles) from a planar laser scan.
- ``association``: gated nearest neighbour, ambiguity test, failure detector (§3.1).
- ``cekf``: EKF-SLAM and the Compressed EKF (ref. [9]) in one class, ``CekfSlam``.
- ``pf``: re-referenced, de-correlated map (eqs. 10–11), helix initialisation (eqs. 12–13),
  association-free likelihood (eq. 9) and SIR localisation.
- ``hybrid``: ``HybridSlam``, the switching architecture, driven one input / one scan at a time.
- ``streams``: ``StreamMerger``, the watermark merge of the input and scan streams into stamp order.
- ``sim``: the Fig. 1 loop-closure world; ``victoria``: the real-data loader and GPS evaluation.
- ``profiles``: the named settings ``victoria_park`` and ``loop_sim`` (node profiles, experiments).
- ``blas``: ``single_threaded_blas``, the context the filter runs in (node and experiments).

Bad input (for a node): ``hybrid.valid_observations`` / ``filter_observations`` are the core's
rule for unusable observation rows; ``HybridSlam.process_input``/``process_scan`` return ``False``
and leave the state untouched for a time stamp earlier than the last one.
"""

from track_core.slam.cekf import CekfSlam, SlamParams
from track_core.slam.hybrid import Event, HybridParams, HybridSlam, filter_observations, valid_observations
from track_core.slam.models import VehicleParams
from track_core.slam.pf import ParticleLocaliser, PFParams

__all__ = ['CekfSlam', 'Event', 'HybridParams', 'HybridSlam', 'PFParams', 'ParticleLocaliser', 'SlamParams',
           'VehicleParams', 'filter_observations', 'valid_observations']

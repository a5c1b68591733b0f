"""Constant-velocity wiring demo: a seeded truth simulator and a Kalman position tracker.

It exists to prove the ROS plumbing (nodes, recording, replay, launcher) on a problem whose
answer is known: the tracker's NEES must match its χ² distribution.
"""

from track_core.demo.simulator import CVTarget
from track_core.demo.tracker import CVKalmanTracker

__all__ = ['CVKalmanTracker', 'CVTarget']

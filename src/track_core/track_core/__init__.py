"""track_core: the ROS-free numerical cores of the tracking package set.

Layering rule: nothing under this package imports rclpy, ROS messages or the upper
packages (track_msgs_py, track_nodes). ``test/unit/test_layering.py`` enforces it.

- ``filters``: blocks every system shares (Kalman steps, Gaussian helpers, motion models).
- ``demo``: the constant-velocity wiring demo used by the foundation scenario.
- one sub-package per paper, added by the issues that implement them.
- ``cli``: ``track-experiment`` and ``track-bench`` with their entry-point registries.
"""

__version__ = '0.1.0'

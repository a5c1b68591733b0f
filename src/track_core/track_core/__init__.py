"""track_core: the ROS-free numerical cores of the tracking package set.

Layering rule: nothing under this package imports rclpy, ROS messages or the upper
packages (track_msgs_py, track_nodes, track_experiments), and it needs numpy and scipy only.
``test/unit/track_core/test_layering.py`` enforces it.

- ``filters``: blocks every system shares (Kalman steps, Gaussian helpers, motion models).
- ``demo``: the constant-velocity demo of the ``demo`` scenario.
- one sub-package per paper (``sonar``, ``geofeasibility``, ``rfid``, ``idsq``, ``slam``) and the
  maritime picture (``fusion``, ``ais``); each has a README. Their experiments and benchmarks are
  in the ``track_experiments`` package.
"""

__version__ = '0.1.0'

"""ament_python package track_msgs_py: the only layer that knows core types and ROS messages (metadata in setup.cfg)."""
from setuptools import setup

setup()

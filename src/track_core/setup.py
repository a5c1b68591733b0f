"""ament_python package track_core: numerical cores, no ROS imports (metadata in setup.cfg)."""
from setuptools import setup

setup()

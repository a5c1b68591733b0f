"""ament_python package track_experiments: experiments and benchmarks (metadata in setup.cfg)."""
from setuptools import setup

setup()

"""Experiments and benchmarks of the tracking package set.

``track-experiment NAME`` reproduces a table or figure of a paper (or runs the soak and fuzz
campaigns); ``track-bench NAME`` times our code against a baseline or peer in the same run. Both
are ``cli.py``; the entries register in ``setup.cfg``. One sub-package per system, each with
``experiments.py`` and ``bench.py``; figures go through ``plotting.pyplot``.
"""

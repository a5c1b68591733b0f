"""Experiments and benchmarks of ``track_core.idsq``."""

"""Simulators and sources: seeded truths and sensor reports for every scenario."""

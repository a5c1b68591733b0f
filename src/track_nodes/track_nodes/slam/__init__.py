"""Hybrid CEKF/PF SLAM on vehicle inputs and laser scans."""

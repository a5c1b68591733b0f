"""The launcher's command line (``python -m track_nodes.launch --help``)."""

from __future__ import annotations

import argparse
from pathlib import Path


def parse_args(argv: list[str] | None, description: str) -> argparse.Namespace:
    ap = argparse.ArgumentParser(prog='python -m track_nodes.launch', description=description)
    ap.add_argument('scenario', help='scenario name (config/<name>.yaml) or a path to a .yaml file')
    ap.add_argument('--record', nargs='?', const='', default=None, metavar='NAME',
                    help='record to bags/NAME/ (default NAME: <scenario>-<timestamp>)')
    ap.add_argument('--duration', type=float, default=None, help='run length in node time [s]')
    ap.add_argument('--processes', action='store_true', help='one process per node')
    ap.add_argument('--hosts', type=int, default=0, metavar='N',
                    help='with --processes: spread the nodes over N simulated hosts (network namespaces, root)')
    ap.add_argument('--params', type=Path, action='append', default=[], metavar='FILE',
                    help='extra params file on top of the scenario (repeat it: each on top of the ones before)')
    ap.add_argument('--rate', type=float, default=None,
                    help='drive /clock at R x real time; 0 = wall time (default: the scenario)')
    ap.add_argument('--network', action='store_true',
                    help="discover beyond localhost (the environment's ROS_AUTOMATIC_DISCOVERY_RANGE)")
    ap.add_argument('--watchdog', type=float, default=None, metavar='S',
                    help='stop when /clock has not advanced for S wall seconds (default: from the graph)')
    ap.add_argument('--epoch', default='now', metavar='E',
                    help="node time at which /clock starts: 'now' (default), whole seconds since 1970, "
                         'or an ISO date (UTC)')
    return ap.parse_args(argv)

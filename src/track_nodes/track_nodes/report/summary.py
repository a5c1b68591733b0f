"""One-screen summary of a recorded bag, printed by the launcher after a recorded run.

Generic part: path, duration, messages per topic. Scenario part (``summary:`` in the
scenario's ``track_launch`` entry): the scenario's metrics against truth, from its module in
``track_nodes.report`` (``SCENARIO_METRICS``); a scenario with a picture (maritime) writes it into
the bag directory.

The same as an executable, for a bag recorded any other way (``ros2 launch ... record:=NAME`` runs it
at the end): ``track-summary BAG [--scenario NAME]`` (``ros2 run track_nodes summary BAG ...``).
Without ``--scenario``, a bag named ``<scenario>`` or ``<scenario>-<anything>`` (the launcher's
default name) gets that scenario's part; else only the generic part.
"""

from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Sequence
from pathlib import Path

from rosbags.rosbag2 import Reader

from track_nodes.report import ais, demo, fusion, idsq, maritime_summary, rfid, slam, sonar

SCENARIO_METRICS = {
    'demo': demo.demo_metrics,
    'fusion': fusion.fusion_metrics,
    'sonar': sonar.sonar_metrics,
    'rfid': rfid.rfid_metrics,
    'slam': slam.slam_metrics,
    'idsq': idsq.idsq_metrics,
    'ais': ais.ais_metrics,
    'maritime': maritime_summary.maritime_metrics,
}

FOLD_AT = 5  # topics that differ only in their numbers (per-sensor topics) list as one line from this many


def summarize(bag: Path, scenario: str | None = None) -> list[str]:
    lines = [f'bag: {bag.resolve()}']
    with Reader(bag) as reader:
        lines.append(f'duration {reader.duration * 1e-9:.1f} s, {reader.message_count} messages')
        families: dict[str, list] = {}
        for conn in reader.connections:
            families.setdefault(re.sub(r'\d+', '*', conn.topic), []).append(conn)
        for key in sorted(families):
            conns = families[key]
            if len(conns) >= FOLD_AT:
                lines.append(f'  {key:<28} {f"({len(conns)} topics)":<44} {sum(c.msgcount for c in conns):>7}')
                continue
            for conn in sorted(conns, key=lambda c: c.topic):
                lines.append(f'  {conn.topic:<28} {conn.msgtype:<44} {conn.msgcount:>7}')
    if scenario in SCENARIO_METRICS:
        lines += SCENARIO_METRICS[scenario](bag)
    return lines


def print_summary(bag: Path, scenario: str | None = None) -> None:
    print('\n'.join(summarize(bag, scenario)), flush=True)


PROG = 'track-summary'


def scenario_of(bag: Path) -> str | None:
    """The scenario a bag's name says (``maritime``, ``maritime-20261205-101500``), or None."""
    head = bag.resolve().name.split('-', 1)[0]
    return head if head in SCENARIO_METRICS else None


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog=PROG, description='Summary (and picture) of a recorded bag: messages per '
                                 "topic, then the scenario's metrics against truth.")
    ap.error = lambda message: ap.exit(2, f'{PROG}: {message}\n')  # one line
    ap.add_argument('bag', type=Path, metavar='BAG', help='bag directory (metadata.yaml and .mcap)')
    ap.add_argument('--scenario', choices=sorted(SCENARIO_METRICS), default=None,
                    help="the scenario's metrics (default: from the bag's name, else none)")
    args = ap.parse_args(sys.argv[1:] if argv is None else list(argv))
    if not (args.bag / 'metadata.yaml').is_file():
        print(f'{PROG}: {args.bag}: no bag there (no metadata.yaml; a killed recorder: track-bag-recover)',
              file=sys.stderr)
        return 2
    print_summary(args.bag, args.scenario or scenario_of(args.bag))
    return 0


if __name__ == '__main__':
    raise SystemExit(main())

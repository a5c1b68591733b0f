"""One-screen summary of a recorded bag, printed by the launcher after a recorded run.

Generic part: path, duration, messages per topic. Scenario part (``summary:`` in the
scenario's ``track_launch`` entry): the scenario's metrics against truth, from its module in
``track_nodes.report`` (``SCENARIO_METRICS``).
"""

from __future__ import annotations

import re
from pathlib import Path

from rosbags.rosbag2 import Reader

from track_nodes.report import ais, demo, fusion, idsq, maritime, rfid, slam, sonar

SCENARIO_METRICS = {
    'demo': demo.demo_metrics,
    'fusion': fusion.fusion_metrics,
    'sonar': sonar.sonar_metrics,
    'rfid': rfid.rfid_metrics,
    'slam': slam.slam_metrics,
    'idsq': idsq.idsq_metrics,
    'ais': ais.ais_metrics,
    'maritime': maritime.maritime_metrics,
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

"""One-screen summary of a recorded bag, printed by the launcher after a recorded run.

Generic part: path, duration, messages per topic. Scenario part (``summary:`` in the
scenario's ``track_launch`` entry): the scenario's metrics against truth, from its module in
``track_nodes.report`` (``SCENARIO_METRICS``); a scenario with a picture (maritime) writes it into
the bag directory.

The same as an executable, for a bag recorded any other way (``ros2 launch ... record:=NAME`` runs it
at the end): ``track-summary BAG [--scenario NAME]`` (``ros2 run track_nodes summary BAG ...``).
Without ``--scenario``, a bag named ``<scenario>`` or ``<scenario>-<anything>`` (the launcher's
default name) gets that scenario's part; else only the generic part.

``--duration D`` (node seconds; ``ros2 launch`` passes the run's): a run whose /clock did not reach D
(the recorder notes the first and the last /clock value it received in the bag's ``custom_data``) is
a cut run: the summary says so in its first line after the path and exits 1, so a stop that reached
only the clock node is not taken for a complete run. A bag without those notes (wall time) is not
judged.
"""

from __future__ import annotations

import argparse
import contextlib
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
CLOCK_SPAN = ('clock_first_ns', 'clock_last_ns')  # the recorder's notes (bag/recorder.py)
CUT_SLACK = 1.0  # [node s] a /clock that stopped this close to the duration ran it (its last tick may be lost)
EXIT_CUT = 1


def clock_ran(bag: Path) -> float | None:
    """How many node seconds /clock ran while ``bag`` was recorded (the recorder's notes), or None."""
    import yaml

    with contextlib.suppress(OSError, yaml.YAMLError, TypeError, ValueError, KeyError):
        info = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
        custom = info.get('custom_data') or {}
        first, last = (int(custom[key]) for key in CLOCK_SPAN)
        return (last - first) * 1e-9
    return None


def cut_line(bag: Path, duration: float | None) -> str | None:
    """The line that says the run of ``bag`` was cut before ``duration``, or None (complete, or not known)."""
    ran = clock_ran(bag)
    if not duration or ran is None or ran >= duration - CUT_SLACK:
        return None
    return f'CUT: /clock ran {ran:.1f} s of the run\'s {duration:g} s: the run was stopped before its end'


def summarize(bag: Path, scenario: str | None = None, duration: float | None = None) -> list[str]:
    lines = [f'bag: {bag.resolve()}']
    if (cut := cut_line(bag, duration)) is not None:
        lines.append(cut)
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


def print_summary(bag: Path, scenario: str | None = None, duration: float | None = None) -> None:
    print('\n'.join(summarize(bag, scenario, duration)), flush=True)


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
    ap.add_argument('--duration', type=float, default=None, metavar='S',
                    help='the run\'s length in node seconds: a run whose /clock stopped earlier is marked cut, exit 1')
    args = ap.parse_args(sys.argv[1:] if argv is None else list(argv))
    if not (args.bag / 'metadata.yaml').is_file():
        print(f'{PROG}: {args.bag}: no bag there (no metadata.yaml; a killed recorder: track-bag-recover)',
              file=sys.stderr)
        return 2
    from track_nodes.bag.api import BagError, one_line, open_bag_checked

    try:  # a broken, unreadable or damaged bag (a chunk CRC) is one line, never a traceback
        open_bag_checked(args.bag).close()
        lines = summarize(args.bag, args.scenario or scenario_of(args.bag), args.duration)
    except BagError as exc:
        print(f'{PROG}: {exc}', file=sys.stderr)
        return 2
    except Exception as exc:  # messages that do not decode (a bag written without CRCs) raise anything
        print(f'{PROG}: {args.bag}: cannot summarize: {type(exc).__name__}: {one_line(exc)}', file=sys.stderr)
        return 2
    print('\n'.join(lines), flush=True)
    return EXIT_CUT if cut_line(args.bag, args.duration) is not None else 0


if __name__ == '__main__':
    raise SystemExit(main())

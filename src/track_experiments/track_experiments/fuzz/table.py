"""The fuzz table: for every subscribing node configuration, how to run and judge it.

A ``FuzzCase`` names a scenario file (``config/<scenario>.yaml``: every node's parameters), the
nodes to build in-process from it (``executable``, ``node name``), the ``target`` whose
subscriptions are attacked (all of them but ``skip_topics``: topics and types are read from the
node itself, so a new subscription is fuzzed without editing this table), and the ``alive`` topics
that must get new output after the attack. The other nodes are the valid-input drivers: the
scenario's own sources, so valid messages are interleaved with the bad ones all along.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from track_msgs_py.topics import (
    DEMO_TRACK,
    FUSION_SCORES,
    IDSQ_LEADER,
    RFID_COMMAND,
    RFID_STEP,
    SLAM_POSE,
    SONAR_CONTACTS,
    SONAR_ESTIMATE,
    SONAR_TARGET_STATUS,
)


@dataclass(frozen=True)
class FuzzCase:
    name: str
    scenario: str
    nodes: tuple[tuple[str, str], ...]
    target: str
    alive: tuple[str, ...]
    overrides: dict[str, dict[str, Any]] = field(default_factory=dict)
    skip_topics: frozenset[str] = frozenset()
    min_output: int = 2
    sim_rate: float = 0.0  # > 0: the nodes use sim time, and the prober drives /clock at this rate
    attack_span: float = 60.0  # sim time: the attack spans at most this many sim s, whatever its length

    def config_path(self) -> Path:
        from track_nodes.launch.scenario import find_scenario
        return find_scenario(self.scenario)


def _idsq_nodes(n: int) -> tuple[tuple[str, str], ...]:
    """vehicle_sim and the first ``n`` sensors of config/idsq.yaml (the types alternate there as listed)."""
    from track_nodes.launch.scenario import load_scenario
    sc = load_scenario('idsq')
    return tuple((s.executable, s.name) for s in sc.nodes[:n + 1])


# The search must outlast the attack: found within 1 mm only (in practice never), no step limit.
SONAR_NODES = (('smart_target', 'smart_target'), ('sonar_sim', 'sonar_sim'), ('sonar_observer', 'sonar_observer'))
RFID_ENDLESS = {'rfid_reader': {'found_radius': 1e-3}, 'rfid_guidance': {'max_steps': 1_000_000}}
FUSION_FAST = {'radar': {'period': 0.05}, 'patrol': {'period': 0.1}, 'fusion': {'rate': 20.0}}


def _ais_live_overrides() -> dict[str, dict[str, Any]]:
    """The live AIS feed on a free UDP port (a scenario running beside the fuzzer keeps 10110), and a NavSatFix
    input on the fusion node, so its GNSS path and its map_datum subscription are attacked too."""
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(('127.0.0.1', 0))
        port = s.getsockname()[1]
    return {'nmea_player': {'port': port}, 'ais_nmea_source': {'udp_port': port},
            'fusion': {'navsatfix_topics': ['/gps/fix']}}


def cases() -> dict[str, FuzzCase]:
    idsq = _idsq_nodes(24)
    doa = next(name for exe, name in idsq if exe == 'doa_sensor')
    acoustic = next(name for exe, name in idsq if exe == 'acoustic_sensor')
    table = [
        FuzzCase('demo_tracker', 'demo', (('demo_target', 'demo_target'), ('demo_tracker', 'demo_tracker')),
                 'demo_tracker', (DEMO_TRACK,)),
        FuzzCase('fusion', 'fusion', (('report_source', 'radar'), ('report_source', 'patrol'), ('fusion', 'fusion')),
                 'fusion', (FUSION_SCORES,), overrides=FUSION_FAST),
        FuzzCase('fusion_ais', 'ais', (('ais_source', 'radar'), ('ais_source', 'patrol'), ('fusion', 'fusion')),
                 'fusion', (FUSION_SCORES,), sim_rate=5.0),
        FuzzCase('fusion_ais_live', 'ais_live', (('nmea_player', 'nmea_player'), ('ais_nmea_source', 'ais_nmea_source'),
                                                 ('ais_source', 'radar'), ('fusion', 'fusion')),
                 'fusion', (FUSION_SCORES,), overrides=_ais_live_overrides(), sim_rate=5.0),
        FuzzCase('fusion_maritime', 'maritime', (('smart_target', 'smart_target'), ('sonar_sim', 'sonar_sim'),
                                                 ('sonar_observer', 'sonar_observer'), ('report_source', 'radar'),
                                                 ('fusion', 'fusion')),
                 'fusion', (FUSION_SCORES,)),
        FuzzCase('slam', 'slam_sim', (('slam_sim', 'slam_sim'), ('slam', 'slam')), 'slam', (SLAM_POSE,)),
        FuzzCase('sonar_observer', 'sonar', SONAR_NODES, 'sonar_observer', (SONAR_ESTIMATE,), sim_rate=2.0),
        FuzzCase('sonar_sim', 'sonar', SONAR_NODES, 'sonar_sim', (SONAR_CONTACTS,), sim_rate=2.0),
        FuzzCase('smart_target', 'sonar', SONAR_NODES, 'smart_target', (SONAR_TARGET_STATUS,), sim_rate=2.0),
        FuzzCase('acoustic_sensor', 'idsq', idsq, acoustic, (IDSQ_LEADER,), min_output=4, sim_rate=1.0,
                 attack_span=15.0),
        FuzzCase('doa_sensor', 'idsq', idsq, doa, (IDSQ_LEADER,), min_output=4, sim_rate=1.0,
                 attack_span=15.0),
        FuzzCase('rfid_reader', 'rfid', (('rfid_reader', 'rfid_reader'), ('rfid_guidance', 'rfid_guidance')),
                 'rfid_reader', (RFID_STEP,), overrides=RFID_ENDLESS),
        FuzzCase('rfid_guidance', 'rfid', (('rfid_reader', 'rfid_reader'), ('rfid_guidance', 'rfid_guidance')),
                 'rfid_guidance', (RFID_COMMAND,), overrides=RFID_ENDLESS),
    ]
    return {c.name: c for c in table}


def default_template(cls, node) -> Any:
    """A plausible message of ``cls`` for a topic no driver published: stamped now, frame ``map``."""
    msg = cls()
    if hasattr(msg, 'header'):
        sec, nsec = divmod(node.get_clock().now().nanoseconds, 10**9)
        msg.header.stamp.sec, msg.header.stamp.nanosec = int(sec), int(nsec)
        msg.header.frame_id = 'map'
    for holder in ('pose', 'twist'):
        inner = getattr(msg, holder, None)
        if inner is not None and hasattr(inner, 'covariance'):
            inner.covariance[::7] = 1.0
    return msg

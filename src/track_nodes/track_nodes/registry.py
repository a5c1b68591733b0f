"""Every executable of track_nodes and the class that runs it: ``executable → 'module:Class'``.

The ``ros2 run`` shims (``lib/track_nodes/<executable>``), ``python -m track_nodes
<executable>``, the launcher's scenarios and ``ros2 launch`` all resolve names here, so a node
can move between sub-packages without any of them changing.
"""

from __future__ import annotations

import importlib

NODES = {
    # one sub-package per system: the simulator or source beside the estimator it feeds
    'demo_target': 'track_nodes.demo.demo_target:DemoTargetNode',
    'demo_tracker': 'track_nodes.demo.demo_tracker:DemoTrackerNode',
    'smart_target': 'track_nodes.sonar.smart_target:SmartTargetNode',
    'sonar_sim': 'track_nodes.sonar.sonar_sim:SonarSimNode',
    'sonar_observer': 'track_nodes.sonar.sonar_observer:SonarObserverNode',
    'vehicle_sim': 'track_nodes.idsq.vehicle_sim:VehicleSimNode',
    'acoustic_sensor': 'track_nodes.idsq.sensor:AcousticSensorNode',
    'doa_sensor': 'track_nodes.idsq.sensor:DoaSensorNode',
    'rfid_reader': 'track_nodes.rfid.rfid_reader:RfidReaderNode',
    'rfid_guidance': 'track_nodes.rfid.rfid_guidance:RfidGuidanceNode',
    'rfid_log_reader': 'track_nodes.rfid.rfid_log_reader:RfidLogReaderNode',
    'rfid_llrp_reader': 'track_nodes.rfid.rfid_llrp_reader:RfidLlrpReaderNode',
    'slam_sim': 'track_nodes.slam.slam_sim:SlamSimNode',
    'slam': 'track_nodes.slam.slam:SlamNode',
    'landmark_extractor': 'track_nodes.slam.landmark_extractor:LandmarkExtractorNode',
    'report_source': 'track_nodes.fusion.report_source:ReportSourceNode',
    'ais_source': 'track_nodes.fusion.ais_source:AisSourceNode',
    'ais_nmea_source': 'track_nodes.fusion.ais_nmea_source:AisNmeaSourceNode',
    'nmea_player': 'track_nodes.fusion.nmea_player:NmeaPlayerNode',
    'fusion': 'track_nodes.fusion.fusion:FusionNode',
    # bag tools that are nodes
    'recorder': 'track_nodes.bag.recorder:RecorderNode',
    'player': 'track_nodes.bag.player:PlayerNode',
    # the live view
    'foxglove_bridge': 'track_nodes.foxglove.bridge:FoxgloveBridgeNode',
    # the launcher's /clock driver, for ros2 launch
    'clock': 'track_nodes.launch.clock:ClockNode',
}

# The managed (lifecycle) versions of the estimator nodes: ``lifecycle_<executable>`` is the node of
# ``<executable>`` run through configure → activate → deactivate → cleanup (track_nodes.base.lifecycle).
LIFECYCLE = {f'lifecycle_{exe}': NODES[exe] for exe in ('demo_tracker', 'fusion', 'sonar_observer', 'slam',
                                                        'rfid_guidance')}

# Executables whose main is not TrackNode.main (they parse their own command line first). All take
# sys.argv-style arguments (program name first) but bag_recover and summary, plain argparse tools.
MAINS = {
    'recorder': 'track_nodes.bag.recorder:main',
    'player': 'track_nodes.bag.player:main',
    'foxglove_bridge': 'track_nodes.foxglove.bridge:main',
    'bag_recover': 'track_nodes.bag.recover:main',
    'node_group': 'track_nodes.launch.group:main',
    'summary': 'track_nodes.report.summary:main',
}
PLAIN_ARGV = frozenset({'bag_recover', 'summary'})


class UnknownExecutableError(KeyError):
    """No executable of that name."""


def _resolve(target: str):
    module, _, attr = target.partition(':')
    return getattr(importlib.import_module(module), attr)


def node_class(executable: str):
    """The node class of ``executable`` (a ``lifecycle_`` one: the managed version of its node)."""
    if executable in LIFECYCLE:
        from track_nodes.base.lifecycle import managed

        return managed(_resolve(LIFECYCLE[executable]))
    try:
        return _resolve(NODES[executable])
    except KeyError:
        raise UnknownExecutableError(executable) from None


def main_of(executable: str):
    """The ``main(argv) -> int`` of ``executable``; ``argv`` is sys.argv-style (program name first)."""
    if executable in PLAIN_ARGV:
        plain = _resolve(MAINS[executable])
        return lambda argv: plain(list(argv)[1:])
    if executable in MAINS:
        return _resolve(MAINS[executable])
    return node_class(executable).main


def executables() -> list[str]:
    return sorted({*NODES, *LIFECYCLE, *MAINS})

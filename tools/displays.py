"""Display configs for RViz 2 and Foxglove, one per scenario, from one description each.

``SCENES`` names, per scenario, the topics worth drawing and how (the message type comes from
``topics.TOPICS``; the drawing from the type: markers, clouds coloured by a field, odometry with its
2σ covariance, pose arrays). ``rviz_config`` and ``foxglove_layout`` turn one scene into an RViz 2
``.rviz`` file and a Foxglove layout (``.json``: a 3D panel following ``map`` plus a raw-message
panel). RViz draws every type of a scene; Foxglove's 3D panel draws neither Odometry nor
PointStamped (``display.FOXGLOVE_3D_TYPES``), so its layout names their display twins
(``<topic>/pose``, published beside them: ``base/twins.py``) instead; ``undrawn`` checks a layout
against the topics and types a run published. The files in ``src/track_nodes/displays/`` (installed
to ``share/track_nodes/displays/``) are written by ``.venv/bin/python tools/displays.py [DIR]``; a test
keeps them equal to this (``test_displays``), and the scenario tests check a recorded bag with ``undrawn_in_bag``.

    rviz2 -d $(ros2 pkg prefix track_nodes)/share/track_nodes/displays/maritime.rviz
    Foxglove: Layouts → Import from file… → share/track_nodes/displays/maritime.json
"""

from __future__ import annotations

import json
import sys
from dataclasses import dataclass
from pathlib import Path

import yaml

from track_msgs_py.display import FOXGLOVE_3D_TYPES
from track_msgs_py.topics import DISPLAY_TWINS, TOPICS, TWIN_TYPES, display_twin


@dataclass(frozen=True)
class Layer:
    topic: str
    msgtype: str = ''  # '' → from topics.TOPICS
    color_field: str = ''  # PointCloud2: colour by this field
    size: float = 1.0  # PointCloud2 point size / arrow length [m]
    rgb: tuple[int, int, int] = (255, 255, 255)

    def type_name(self) -> str:
        return self.msgtype or TOPICS[self.topic].msgtype

    def foxglove(self) -> tuple[str, str]:
        """(topic, type) of what Foxglove's 3D panel draws for this layer: the topic, or its display twin."""
        if self.type_name() in FOXGLOVE_3D_TYPES or self.topic not in DISPLAY_TWINS:
            return self.topic, self.type_name()  # drawable, or undrawn for lack of a twin (a test says so)
        return display_twin(self.topic), TWIN_TYPES[self.type_name()]


@dataclass(frozen=True)
class Scene:
    name: str
    layers: tuple[Layer, ...]
    centre: tuple[float, float]  # view centre in map [m]
    scale: float  # RViz top-down pixels per metre
    raw_topic: str  # the topic the raw-message panel shows


SCENES = {
    'maritime': Scene('maritime', (
        Layer('/idsq/belief', color_field='p', size=5.0),
        Layer('/idsq/layout', color_field='type', size=3.0),
        Layer('/idsq/markers'), Layer('/sonar/markers'), Layer('/fusion/markers'),
        # the tracks: the observer's (SS-PF), the network's (IDSQ), the radar's of the decoy; their truths
        Layer('/sonar/estimate', rgb=(80, 160, 255), size=10.0), Layer('/idsq/estimate', rgb=(255, 160, 0), size=10.0),
        Layer('/radar/t0', rgb=(255, 80, 200), size=10.0),
        Layer('/sonar/target/truth', rgb=(255, 255, 255), size=10.0),
        Layer('/radar/truth', rgb=(200, 200, 200), size=10.0),
        Layer('/sonar/observer/odom', rgb=(0, 220, 120), size=10.0),  # the observer AUV
        Layer('/sonar/ping', rgb=(255, 60, 60), size=15.0),  # where it last pinged
        Layer('/sonar/particles', rgb=(80, 160, 255), size=3.0),
    ), centre=(150.0, 200.0), scale=2.0, raw_topic='/fusion/scores'),
    'slam': Scene('slam', (
        Layer('/slam/map'), Layer('/slam/scan', color_field='range', size=0.3),
        Layer('/slam/pose', rgb=(255, 160, 0)), Layer('/slam/truth', rgb=(255, 255, 255)),
        Layer('/slam/particles', rgb=(255, 160, 0)),
    ), centre=(0.0, 0.0), scale=5.0, raw_topic='/slam/mode'),
    'rfid': Scene('rfid', (
        Layer('/rfid/phase', color_field='phase', size=0.05), Layer('/rfid/particles', rgb=(255, 160, 0)),
        Layer('/rfid/user/pose', rgb=(80, 160, 255)), Layer('/rfid/tag_estimate', rgb=(0, 220, 120)),
    ), centre=(0.0, 0.0), scale=40.0, raw_topic='/rfid/command'),
}

_RVIZ_CLASS = {
    'visualization_msgs/msg/MarkerArray': 'rviz_default_plugins/MarkerArray',
    'sensor_msgs/msg/PointCloud2': 'rviz_default_plugins/PointCloud2',
    'nav_msgs/msg/Odometry': 'rviz_default_plugins/Odometry',
    'geometry_msgs/msg/PoseWithCovarianceStamped': 'rviz_default_plugins/PoseWithCovariance',
    'geometry_msgs/msg/PoseArray': 'rviz_default_plugins/PoseArray',
    'geometry_msgs/msg/PoseStamped': 'rviz_default_plugins/Pose',
    'geometry_msgs/msg/PointStamped': 'rviz_default_plugins/PointStamped',
}


def _rgb(c: tuple[int, int, int]) -> str:
    return '; '.join(str(v) for v in c)


def _rviz_display(layer: Layer) -> dict:
    cls = _RVIZ_CLASS[layer.type_name()]
    spec = TOPICS.get(layer.topic)
    reliable = spec is None or spec.qos != 'sensor'
    d = {'Class': cls, 'Enabled': True, 'Name': layer.topic,
         'Topic': {'Value': layer.topic, 'Depth': 5, 'History Policy': 'Keep Last',
                   'Reliability Policy': 'Reliable' if reliable else 'Best Effort',
                   'Durability Policy': 'Transient Local' if spec is not None and spec.qos == 'static' else 'Volatile'}}
    if cls.endswith('PointCloud2'):
        d.update({'Style': 'Flat Squares', 'Size (m)': layer.size, 'Color Transformer': 'Intensity',
                  'Channel Name': layer.color_field, 'Autocompute Intensity Bounds': True, 'Decay Time': 0})
    elif cls.endswith('Odometry'):
        d.update({'Keep': 1, 'Shape': {'Value': 'Arrow', 'Color': _rgb(layer.rgb)},
                  'Covariance': {'Value': True, 'Position': {'Value': True, 'Scale': 2.0}}})
    elif cls.endswith('PoseWithCovariance'):
        d.update({'Shape': {'Value': 'Arrow', 'Color': _rgb(layer.rgb)},
                  'Covariance': {'Value': True, 'Position': {'Value': True, 'Scale': 2.0}}})
    elif cls.endswith(('PoseArray', 'Pose', 'PointStamped')):
        d.update({'Color': _rgb(layer.rgb)})
    return d


def rviz_config(scene: Scene) -> dict:
    """An RViz 2 config (the YAML layout of a saved ``.rviz``): fixed frame ``map``, top-down view."""
    displays = [{'Class': 'rviz_default_plugins/Grid', 'Enabled': True, 'Name': 'Grid', 'Cell Size': 10,
                 'Plane Cell Count': 100, 'Reference Frame': '<Fixed Frame>'},
                {'Class': 'rviz_default_plugins/TF', 'Enabled': True, 'Name': 'TF', 'Show Names': True}]
    displays += [_rviz_display(layer) for layer in scene.layers]
    return {
        'Panels': [{'Class': 'rviz_common/Displays', 'Name': 'Displays'}],
        'Visualization Manager': {
            'Class': '', 'Name': 'root', 'Enabled': True, 'Displays': displays,
            'Global Options': {'Background Color': '48; 48; 48', 'Fixed Frame': 'map', 'Frame Rate': 30},
            'Tools': [{'Class': 'rviz_default_plugins/MoveCamera'}, {'Class': 'rviz_default_plugins/Select'}],
            'Views': {'Current': {'Class': 'rviz_default_plugins/TopDownOrtho', 'Name': 'Current View',
                                  'Scale': scene.scale, 'X': scene.centre[0], 'Y': scene.centre[1],
                                  'Target Frame': '<Fixed Frame>'}},
        },
        'Window Geometry': {'Height': 900, 'Width': 1400},
    }


def foxglove_layout(scene: Scene) -> dict:
    """A Foxglove layout: a 3D panel following ``map`` with the scene's topics, a raw-message panel."""
    topics = {}
    for layer in scene.layers:
        topic, msgtype = layer.foxglove()
        t: dict = {'visible': True}
        color = '#{:02x}{:02x}{:02x}'.format(*layer.rgb)
        arrow = [layer.size, round(0.15 * layer.size, 3), round(0.15 * layer.size, 3)]  # length, shaft, head [m]
        if msgtype == 'sensor_msgs/msg/PointCloud2':
            t.update({'colorField': layer.color_field, 'colorMode': 'colormap', 'colorMap': 'turbo',
                      'pointSize': 4, 'pointShape': 'square'})
        elif msgtype in ('geometry_msgs/msg/PoseWithCovarianceStamped', 'geometry_msgs/msg/PoseStamped'):
            t.update({'type': 'arrow', 'color': color, 'arrowScale': arrow})
            if msgtype.endswith('CovarianceStamped'):
                t.update({'showCovariance': True, 'covarianceColor': color + '66'})
        elif msgtype == 'geometry_msgs/msg/PoseArray':
            t.update({'type': 'arrow', 'gradient': [color, color], 'arrowScale': arrow})
        topics[topic] = t
    three_d = {'followTf': 'map', 'followMode': 'follow-none', 'topics': topics,
               'layers': {'grid': {'layerId': 'foxglove.Grid', 'visible': True, 'frameId': 'map', 'size': 1000,
                                   'divisions': 100}},
               'cameraState': {'perspective': False, 'distance': 400.0 / scene.scale * 2, 'phi': 0, 'thetaOffset': 0,
                               'targetOffset': [scene.centre[0], scene.centre[1], 0]}}
    return {'configById': {'3D!main': three_d, 'RawMessages!raw': {'topicPath': scene.raw_topic}},
            'globalVariables': {}, 'userNodes': {}, 'playbackConfig': {'speed': 1},
            'layout': {'first': '3D!main', 'second': 'RawMessages!raw', 'direction': 'row', 'splitPercentage': 72}}


def three_d_topics(layout: dict) -> list[str]:
    """The topics of every 3D panel of a Foxglove layout."""
    return [t for pid, cfg in layout['configById'].items() if pid.startswith('3D!') for t in cfg.get('topics', {})]


def undrawn(layout: dict, published: dict[str, str]) -> list[str]:
    """Why 3D entries of ``layout`` would draw nothing, given the ``published`` topics and their types; [] if none."""
    out = []
    for topic in three_d_topics(layout):
        if topic not in published:
            out.append(f'{topic}: not published')
        elif published[topic] not in FOXGLOVE_3D_TYPES:
            out.append(f'{topic}: {published[topic]} is not drawn by the 3D panel')
    return out


def undrawn_in_bag(name: str, bag: Path) -> list[str]:
    """``undrawn`` of scene ``name``'s Foxglove layout against the topics and types recorded in ``bag``."""
    from rosbags.rosbag2 import Reader

    with Reader(bag) as reader:
        published = {c.topic: c.msgtype for c in reader.connections}
    return undrawn(foxglove_layout(SCENES[name]), published)


def write(out: Path) -> list[Path]:
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, scene in SCENES.items():
        rviz, fox = out / f'{name}.rviz', out / f'{name}.json'
        rviz.write_text(yaml.safe_dump(rviz_config(scene), sort_keys=False))
        fox.write_text(json.dumps(foxglove_layout(scene), indent=2) + '\n')
        paths += [rviz, fox]
    return paths


if __name__ == '__main__':
    for path in write(Path(sys.argv[1] if len(sys.argv) > 1 else 'src/track_nodes/displays')):
        print(path)

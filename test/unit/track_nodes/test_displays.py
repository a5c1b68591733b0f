"""The RViz 2 configs and Foxglove layouts (issue 19): generated from launch/displays.py, installed, drawable.

Every display names a topic of our table with a display class RViz has for its type, in the
``map`` fixed frame; the committed files equal what the scene descriptions generate (so a topic
renamed in ``topics.py`` cannot leave a stale config behind); they are installed under
``share/track_nodes/displays``.
"""

from __future__ import annotations

import json

import yaml

from track_msgs_py.topics import TOPICS
from track_nodes.launch.displays import _RVIZ_CLASS, SCENES, foxglove_layout, rviz_config, write

SRC = 'src/track_nodes/displays'


def test_committed_files_are_the_generated_ones(repo, tmp_path):
    for path in write(tmp_path):
        regenerate = f'python -m track_nodes.launch.displays {SRC}'
        assert (repo / SRC / path.name).read_text() == path.read_text(), regenerate


def test_every_display_draws_a_known_topic_in_map():
    for scene in SCENES.values():
        cfg = rviz_config(scene)['Visualization Manager']
        assert cfg['Global Options']['Fixed Frame'] == 'map'
        for d in cfg['Displays'][2:]:
            topic = d['Topic']['Value']
            assert topic in TOPICS and d['Class'] == _RVIZ_CLASS[TOPICS[topic].msgtype], topic
            if TOPICS[topic].qos == 'sensor':
                assert d['Topic']['Reliability Policy'] == 'Best Effort', topic  # else RViz matches nothing
        fox = foxglove_layout(scene)
        assert set(fox['configById']['3D!main']['topics']) == {layer.topic for layer in scene.layers}
        assert fox['configById']['3D!main']['followTf'] == 'map'


def test_installed_beside_the_configs(prefix):
    share = prefix / 'share/track_nodes/displays'
    for name in SCENES:
        yaml.safe_load((share / f'{name}.rviz').read_text())
        json.loads((share / f'{name}.json').read_text())

"""The RViz 2 configs and Foxglove layouts (issue 19): generated from launch/displays.py, installed, drawable.

Every display names a topic of our table with a display class RViz has for its type, in the
``map`` fixed frame; the committed files equal what the scene descriptions generate (so a topic
renamed in ``topics.py`` cannot leave a stale config behind); they are installed under
``share/track_nodes/displays``.
"""

from __future__ import annotations

import json

import yaml

from track_msgs_py.display import FOXGLOVE_3D_TYPES
from track_msgs_py.topics import TOPICS
from track_nodes.launch.displays import (
    _RVIZ_CLASS,
    SCENES,
    foxglove_layout,
    rviz_config,
    three_d_topics,
    undrawn,
    write,
)

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
        assert set(fox['configById']['3D!main']['topics']) == {layer.foxglove()[0] for layer in scene.layers}
        assert fox['configById']['3D!main']['followTf'] == 'map'


def test_every_3d_entry_of_the_shipped_layouts_is_of_a_type_the_panel_draws(repo):
    """Foxglove's 3D panel draws FOXGLOVE_3D_TYPES only (its docs and source): Odometry and PointStamped
    entries name their display twins, which our table types as drawable."""
    published = {topic: spec.msgtype for topic, spec in TOPICS.items()}
    for name in SCENES:
        layout = json.loads((repo / SRC / f'{name}.json').read_text())
        topics = three_d_topics(layout)
        assert topics and undrawn(layout, published) == [], name
    assert not {'nav_msgs/msg/Odometry', 'geometry_msgs/msg/PointStamped'} & FOXGLOVE_3D_TYPES
    # the check can fail: an Odometry entry, as the layouts had before the twins, draws nothing
    assert undrawn({'configById': {'3D!main': {'topics': {'/sonar/estimate': {}}}}}, published) == \
        ['/sonar/estimate: nav_msgs/msg/Odometry is not drawn by the 3D panel']
    assert undrawn({'configById': {'3D!main': {'topics': {'/nowhere': {}}}}}, published) == ['/nowhere: not published']


# The Foxglove SDK's own model of a 3D panel's topic settings, per type we draw (foxglove.layouts)
_SDK_SETTINGS = {
    'visualization_msgs/msg/MarkerArray': 'BaseRendererRosMarkerTopicSettings',
    'sensor_msgs/msg/PointCloud2': 'BaseRendererPointCloudTopicSettings',
    'geometry_msgs/msg/PoseStamped': 'BaseRendererPoseTopicSettings',
    'geometry_msgs/msg/PoseWithCovarianceStamped': 'BaseRendererPoseTopicSettings',
    'geometry_msgs/msg/PoseArray': 'BaseRendererPosesTopicSettings',
}


def test_every_topic_setting_is_one_foxglove_knows_for_its_type(repo):
    """Each 3D entry's keys are fields of the SDK's settings model of its type (an unknown key is ignored by the
    app, silently: a misspelt colour would draw in the default one)."""
    import re

    from foxglove import layouts

    for name in SCENES:
        layout = json.loads((repo / SRC / f'{name}.json').read_text())
        for topic, settings in layout['configById']['3D!main']['topics'].items():
            model = getattr(layouts, _SDK_SETTINGS[TOPICS[topic].msgtype])
            kwargs = {re.sub('([A-Z])', r'_\1', k).lower(): v for k, v in settings.items()}
            assert model(**kwargs)._to_dict().keys() >= settings.keys(), (name, topic)  # TypeError on an unknown key


def test_the_maritime_layout_shows_every_track_its_truth_the_observer_and_the_pings(repo):
    topics = set(three_d_topics(json.loads((repo / SRC / 'maritime.json').read_text())))
    tracks = {'/sonar/estimate/pose', '/idsq/estimate/pose', '/radar/t0'}  # observer, network, radar (the decoy)
    truths = {'/sonar/target/truth/pose', '/radar/truth/pose'}  # the smart target's, the decoy's
    assert tracks | truths | {'/sonar/observer/odom/pose', '/sonar/ping/pose', '/fusion/markers'} <= topics


def test_installed_beside_the_configs(prefix):
    share = prefix / 'share/track_nodes/displays'
    for name in SCENES:
        yaml.safe_load((share / f'{name}.rviz').read_text())
        json.loads((share / f'{name}.json').read_text())

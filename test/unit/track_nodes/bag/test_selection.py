"""The recorder's topic filter: what was asked for, plus where everything is (the transform tree and the
run's map datum) unless ``tf`` is off."""

import pytest

from track_nodes.bag.selection import TopicFilter
from track_nodes.base.params import ParameterError


def test_the_frame_tree_and_the_datum_are_recorded_whatever_the_regex():
    f = TopicFilter([], '^/sonar/', tf=True)
    assert f.wanted('/sonar/contacts') and not f.wanted('/idsq/estimate')
    assert all(f.wanted(t) for t in ('/tf', '/tf_static', '/map_datum'))
    assert '/map_datum' in f.describe()


def test_without_tf_only_what_was_asked_for():
    f = TopicFilter(['map_datum'], '^/sonar/', tf=False)
    assert not f.wanted('/tf') and not f.wanted('/tf_static')
    assert f.wanted('/map_datum')  # listed explicitly
    assert not TopicFilter([], '', tf=False).wanted('/map_datum')


def test_everything_but_the_ros_internals_without_a_filter():
    f = TopicFilter([], '', tf=True)
    assert f.wanted('/anything') and not f.wanted('/rosout') and not f.wanted('/parameter_events')


def test_a_bad_regex_is_one_parameter_error():
    with pytest.raises(ParameterError, match='regex'):
        TopicFilter([], '(', tf=True)

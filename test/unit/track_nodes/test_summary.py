"""summarize(): topic families that differ only in their numbers fold into one line; a broken bag is one line."""

import pytest
from rclpy.serialization import serialize_message
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore
from std_msgs.msg import String

from track_nodes.report.summary import FOLD_AT, summarize


def _bag(path, topics):
    ts = get_typestore(Stores.ROS2_JAZZY)
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        for i, topic in enumerate(topics):
            conn = w.add_connection(topic, 'std_msgs/msg/String', typestore=ts)
            w.write(conn, 1_000 + i, serialize_message(String(data=topic)))


def test_numbered_families_fold_from_fold_at(tmp_path):
    many = [f'/net/sensor_{k}/handoff' for k in range(FOLD_AT)]
    few = [f'/net/node_{k}/status' for k in range(FOLD_AT - 1)]
    _bag(tmp_path / 'b', [*many, *few, '/net/estimate'])
    lines = summarize(tmp_path / 'b')
    folded = [ln for ln in lines if '/net/sensor_*/handoff' in ln]
    assert len(folded) == 1 and f'({FOLD_AT} topics)' in folded[0] and folded[0].split()[-1] == str(FOLD_AT)
    assert not any('/net/sensor_0/handoff' in ln for ln in lines)
    assert sum('/net/node_' in ln for ln in lines) == FOLD_AT - 1          # a smaller family stays listed
    assert any('/net/estimate' in ln for ln in lines)


def test_the_demo_summary_counts_the_estimates_it_leaves_out(monkeypatch):
    """An estimate stamped at no truth time (a hijacked track fed by another publisher) is not matched to a
    truth: the summary says how many were left out instead of quietly scoring the rest."""
    from pathlib import Path

    import numpy as np

    from track_msgs_py.odometry import cv_state_to_odometry
    from track_msgs_py.topics import DEMO_TRACK, DEMO_TRUTH
    from track_nodes.report import demo

    truth = [cv_state_to_odometry(1.0 + k, np.array([k, 1.0, 0.0, 0.0]), np.zeros((4, 4))) for k in range(20)]
    track = [cv_state_to_odometry(1.0 + k, np.array([k, 1.0, 0.0, 0.0]), np.eye(4)) for k in range(20)]
    track += [cv_state_to_odometry(1.5 + k, np.array([1000.0, 0.0, 0.0, 0.0]), np.eye(4)) for k in range(3)]
    monkeypatch.setattr(demo, 'read_topics', lambda bag, topics: {DEMO_TRUTH: truth, DEMO_TRACK: track})
    lines = demo.demo_metrics(Path('unused'))
    assert '20 estimates matched to truth; left out: 3 estimate(s)' in lines[0], lines
    monkeypatch.setattr(demo, 'read_topics', lambda bag, topics: {DEMO_TRUTH: truth, DEMO_TRACK: track[:20]})
    assert 'left out' not in demo.demo_metrics(Path('unused'))[0]


def _broken(tmp_path, how: str, flip_bit):
    """A small bag of ours (chunk CRCs), then broken ``how``."""
    import shutil

    bag = tmp_path / 'b'
    _bag_ours(bag)
    mcap = bag / 'b.mcap'
    if how == 'garbage':
        mcap.write_bytes(mcap.read_bytes()[:8] + bytes((i * 151 + 7) % 256 for i in range(4000)))
    elif how == 'truncated':
        mcap.write_bytes(mcap.read_bytes()[:200])
    elif how == 'missing-mcap':
        mcap.unlink()
    elif how == 'unreadable':
        mcap.unlink()
        mcap.mkdir()  # a directory where the file should be (root reads any file, so no chmod)
    elif how == 'metadata':
        (bag / 'metadata.yaml').write_bytes(b'\x00\xff: [unclosed\n\t- :')
    elif how == 'crc':
        flip_bit(mcap)
    else:
        shutil.rmtree(bag)
    return bag


def _bag_ours(path):
    from track_nodes.bag.typestore import typestore
    from track_nodes.bag.writer import BagWriter

    w = BagWriter(path).open()
    conn = w.add_connection('/t', 'std_msgs/msg/String', typestore=typestore())
    for i in range(20):
        w.write(conn, 1_000 + i, serialize_message(String(data=f'm{i}')))
    w.close()


@pytest.mark.parametrize('how', ['garbage', 'truncated', 'missing-mcap', 'unreadable', 'metadata', 'crc'])
def test_a_broken_bag_is_one_line_and_exit_2(tmp_path, capsys, flip_bit, how):
    from track_nodes.report.summary import main

    bag = _broken(tmp_path, how, flip_bit)
    assert main([str(bag)]) == 2
    out, err = capsys.readouterr()
    assert out == '' and len(err.strip().splitlines()) == 1 and str(bag) in err, err
    assert 'Traceback' not in err
    if how == 'crc':
        assert 'chunk 1 at byte' in err

"""The launcher runs the demo scenario end to end; its bag decodes three independent ways."""

from __future__ import annotations

import importlib
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from rclpy.serialization import deserialize_message
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore

from track_nodes.bag.frames import check_frames

DURATION, PERIOD = 4.0, 0.1  # demo_target period in config/demo.yaml
EPOCH = '2026-01-01T00:00:00'  # both runs of the fixture: a seed and an epoch reproduce every payload
EPOCH_S = 1767225600
N_EXPECTED = round(DURATION / PERIOD)
TOPICS = {'/demo/truth', '/demo/reports', '/demo/track'}


def launch(repo: Path, cwd: Path, env: dict, *extra: str, timeout: float = 120) -> subprocess.CompletedProcess:
    cmd = [sys.executable, '-m', 'track_nodes.launch', str(repo / 'config/demo.yaml'), *extra]
    return subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)


def payloads(bag: Path) -> dict[str, list[bytes]]:
    out: dict[str, list[bytes]] = {}
    with Reader(bag) as reader:
        for conn, _, raw in reader.messages():
            out.setdefault(conn.topic, []).append(bytes(raw))
    return out


@pytest.fixture(scope='module')
def demo_bags(tmp_path_factory, env_factory, repo):
    """The demo recorded twice, same seed, /clock at 20x: (first bag, second bag, first stdout)."""
    cwd = tmp_path_factory.mktemp('launch')
    results = []
    for name in ('run1', 'run2'):
        proc = launch(repo, cwd, env_factory(), '--record', name, '--duration', str(DURATION), '--rate', '20',
                      '--epoch', EPOCH)
        assert proc.returncode == 0, proc.stderr
        results.append(proc)
    return cwd / 'bags/run1', cwd / 'bags/run2', results[0].stdout


def test_launcher_prints_bag_path_and_summary(demo_bags):
    bag, _, stdout = demo_bags
    assert str(bag.resolve()) in stdout
    assert 'position RMSE' in stdout and '/demo/track' in stdout


def test_every_step_recorded_on_every_topic(demo_bags):
    counts = {t: len(v) for t, v in payloads(demo_bags[0]).items()}
    assert set(counts) == TOPICS
    assert all(c == N_EXPECTED for c in counts.values()), counts


def test_every_covariance_of_the_recording_draws_flat(demo_bags):
    """Issue 19: no covariance of the demo (truth, reports, track) is taller in z than in x and y."""
    from track_nodes.bag.check import check_bag

    res = check_bag(demo_bags[0])
    assert res.ok and dict(res.checked) == dict.fromkeys(TOPICS, N_EXPECTED), res.problems


def test_every_frame_of_the_recording_is_placed_in_map(demo_bags):
    assert check_frames(demo_bags[0], stamps=True) == []  # all in map: no /tf needed (the track ids are no frames)


def test_bag_decodes_with_rosbags(demo_bags):
    ts = get_typestore(Stores.ROS2_JAZZY)
    with Reader(demo_bags[0]) as reader:
        msgs = [(c.topic, ts.deserialize_cdr(raw, c.msgtype)) for c, _, raw in reader.messages()]
    truth = [m for t, m in msgs if t == '/demo/truth']
    stamps = [(m.header.stamp.sec - EPOCH_S) + m.header.stamp.nanosec * 1e-9 for m in truth]
    assert stamps == pytest.approx([PERIOD * (k + 1) for k in range(N_EXPECTED)], abs=1e-6)  # 1e-7 s: float seconds
    assert truth[0].child_frame_id == 'demo_target' and truth[0].header.frame_id == 'map'


def test_bag_decodes_with_mcap_and_embedded_schemas(demo_bags):
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    (mcap_file,) = demo_bags[0].glob('*.mcap')
    seen = {}
    with mcap_file.open('rb') as f:
        for _, channel, _, msg in make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages():
            seen.setdefault(channel.topic, []).append(msg)
    assert set(seen) == TOPICS
    assert seen['/demo/reports'][0].header.frame_id == 'map'
    assert len(seen['/demo/reports'][0].pose.covariance) == 36


def test_bag_decodes_with_rclpy(demo_bags):
    with Reader(demo_bags[0]) as reader:
        for conn, _, raw in reader.messages():
            pkg, _, name = conn.msgtype.rpartition('/')
            cls = getattr(importlib.import_module(pkg.replace('/', '.')), name)
            msg = deserialize_message(raw, cls)
            assert msg.header.frame_id == 'map'


def test_same_seed_and_clock_give_identical_payloads(demo_bags):
    first, second = payloads(demo_bags[0]), payloads(demo_bags[1])
    assert first.keys() == second.keys()
    for topic in first:
        assert first[topic] == second[topic], topic


def test_tracker_output_is_accurate(demo_bags):
    from track_nodes.report.demo import demo_metrics

    lines = demo_metrics(demo_bags[0])
    rmse = float(lines[1].split('position RMSE')[1].split()[0])
    assert rmse < 2.0  # report σ is 2 m per axis (2.8 m radial); a working filter beats it


def test_processes_mode_records_the_same_topics(tmp_path, env_factory, repo):
    before = time.time_ns()
    proc = launch(repo, tmp_path, env_factory(), '--processes', '--record', 'p', '--duration', '2', '--rate', '10')
    after = time.time_ns()
    assert proc.returncode == 0, proc.stderr
    counts = {t: len(v) for t, v in payloads(tmp_path / 'bags/p').items()}
    assert set(counts) == TOPICS and all(c == 20 for c in counts.values()), counts
    # Issue 19 item 10: the default epoch is now (its whole minute), so a sim-time bag shows when it was recorded
    with Reader(tmp_path / 'bags/p') as reader:
        assert before - 60 * 10**9 <= reader.start_time <= reader.end_time <= after, (before, reader.start_time, after)


def test_fixed_epoch_starts_the_bag_there(demo_bags):
    with Reader(demo_bags[0]) as reader:
        assert reader.start_time >= EPOCH_S * 10**9 and reader.end_time <= (EPOCH_S + DURATION + 1) * 10**9


def test_bad_epoch_is_one_line_and_exit_2(tmp_path, env_factory, repo):
    from track_nodes.launch.launcher import LaunchError, parse_epoch

    for epoch in ('0', '1.5', 'yesterday', '99999999999'):
        with pytest.raises(LaunchError, match='--epoch'):
            parse_epoch(epoch)
    assert parse_epoch('now') is None and parse_epoch('2026-01-01T00:00:00') == EPOCH_S == parse_epoch(str(EPOCH_S))
    proc = launch(repo, tmp_path, env_factory(), '--duration', '1', '--rate', '10', '--epoch', 'yesterday', timeout=60)
    assert proc.returncode == 2 and proc.stderr.count('\n') == 1 and '--epoch' in proc.stderr, proc.stderr


def test_sigint_stops_cleanly_with_a_complete_bag(tmp_path, env_factory, repo):
    cmd = [sys.executable, '-m', 'track_nodes.launch', str(repo / 'config/demo.yaml'), '--record', 'i',
           '--rate', '1', '--duration', '600']
    proc = subprocess.Popen(cmd, cwd=tmp_path, env=env_factory(), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    bag = tmp_path / 'bags/i'
    deadline = time.monotonic() + 60
    while not list(bag.glob('*.mcap')) and time.monotonic() < deadline:
        time.sleep(0.2)
    time.sleep(3.0)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    assert (bag / 'metadata.yaml').is_file()
    assert len(payloads(bag).get('/demo/truth', [])) > 0


@pytest.mark.parametrize(('args', 'words'), [
    (['no_such_scenario'], 'not found'),
    (['demo', '--rate', '-1'], '--rate must be >= 0'),
    (['demo', '--params', 'missing.yaml'], 'no such file'),
])
def test_bad_input_one_line_exit_2(tmp_path, env_factory, args, words):
    proc = subprocess.run([sys.executable, '-m', 'track_nodes.launch', *args], cwd=tmp_path, env=env_factory(),
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2
    assert words in proc.stderr and len(proc.stderr.strip().splitlines()) == 1 and 'Traceback' not in proc.stderr


def test_refuses_to_overwrite_a_bag(tmp_path, env_factory, repo):
    (tmp_path / 'bags/taken').mkdir(parents=True)
    proc = launch(repo, tmp_path, env_factory(), '--record', 'taken', '--duration', '1')
    assert proc.returncode == 2 and 'exists already' in proc.stderr and 'bags/taken' in proc.stderr


def test_player_replays_the_demo_bag_in_order(demo_bags, ros, prefix):
    """The player replays the recorded demo into a subscriber: every message, in order, same bytes."""
    from nav_msgs.msg import Odometry
    from rclpy.node import Node

    from track_msgs_py.qos import ESTIMATE_QOS

    expected = payloads(demo_bags[0])
    got: dict[str, list[bytes]] = {'/demo/truth': [], '/demo/track': []}
    node = ros.add(Node('replay_sink', context=ros.context))
    for topic in got:
        node.create_subscription(Odometry, topic, lambda raw, t=topic: got[t].append(bytes(raw)),
                                 ESTIMATE_QOS, raw=True)
    # Only the topics subscribed here, so the player's wait for subscribers (60 s: discovery on a loaded
    # machine can take seconds) ends as soon as both are matched.
    player = subprocess.Popen([str(prefix / 'lib/track_nodes/player'), str(demo_bags[0]), '--rate', '4',
                               '--topics', *got, '--wait-subscribers', '60'],
                              env=ros.env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        ros.spin_until(lambda: all(len(got[t]) == len(expected[t]) for t in got) or player.poll() is not None,
                       timeout=180)
        ros.spin_for(0.5)
    finally:
        _, err = player.communicate(timeout=30)
    assert player.returncode == 0, err
    for topic, received in got.items():
        assert received == expected[topic], topic


def test_tracked_sample_bag_is_readable(repo):
    """bags/sample-demo (used by the README) still decodes, holds 100 messages per topic and draws (issue 19)."""
    from track_nodes.bag.check import check_bag

    counts = {t: len(v) for t, v in payloads(repo / 'bags/sample-demo').items()}
    assert counts == dict.fromkeys(TOPICS, 100)
    res = check_bag(repo / 'bags/sample-demo')
    assert res.ok and sum(res.checked.values()) == 300, res.problems


def _layout(bag: Path) -> dict:
    """What a bag's metadata.yaml says about its shape, not its contents: topics, types, offered QoS, distro."""
    import yaml

    meta = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    topics = {t['topic_metadata']['name']: (t['topic_metadata']['type'], t['topic_metadata']['serialization_format'],
                                            t['topic_metadata']['offered_qos_profiles'])
              for t in meta['topics_with_message_count']}
    return {'topics': topics, 'ros_distro': meta['ros_distro'], 'version': meta['version'],
            'storage': meta['storage_identifier'], 'start_ns': meta['starting_time']['nanoseconds_since_epoch']}


def test_tracked_sample_bag_has_the_layout_of_a_fresh_recording(repo, demo_bags):
    """bags/sample-demo was made by today's launcher: same topics, types, QoS and distro as a recording made now,
    and dated like one (sim time from an epoch, not 1970), header stamps included."""
    sample, fresh = _layout(repo / 'bags/sample-demo'), _layout(demo_bags[0])
    assert sample['ros_distro'] == fresh['ros_distro'] == 'jazzy'
    assert sample['topics'] == fresh['topics']
    assert (sample['version'], sample['storage']) == (fresh['version'], fresh['storage']) == (9, 'mcap')
    plausible = (1_767_225_600 * 10**9, time.time_ns() + 86_400 * 10**9)   # 2026-01-01 .. tomorrow
    assert plausible[0] <= sample['start_ns'] <= plausible[1] and plausible[0] <= fresh['start_ns'] <= plausible[1]
    with Reader(repo / 'bags/sample-demo') as reader:
        ts = get_typestore(Stores.ROS2_JAZZY)
        for conn, t, raw in reader.messages():
            stamp = ts.deserialize_cdr(raw, conn.msgtype).header.stamp
            assert stamp.sec * 10**9 + stamp.nanosec == t, (conn.topic, t)  # stamped at its log time, to the ns

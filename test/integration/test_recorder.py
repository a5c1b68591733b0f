"""The recorder: in-process recording, regex discovery, /tf and /tf_static whatever the filter, refusal to
overwrite, signals, SIGKILL recovery."""

from __future__ import annotations

import contextlib
import re
import signal
import subprocess
from pathlib import Path

import pytest
import rclpy
from geometry_msgs.msg import PoseWithCovarianceStamped
from nav_msgs.msg import Odometry
from rclpy.duration import Duration
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message, serialize_message
from rosbags.interfaces import QosDurability, QosReliability
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore
from tf2_msgs.msg import TFMessage

from track_msgs_py.tf import TF, TF_QOS, TF_STATIC, TF_STATIC_QOS, planar_transform, tf_message
from track_nodes.bag.recorder import RecorderNode, parse_cli
from track_nodes.bag.recover import read_broken_mcap

pytestmark = pytest.mark.integration

N = 20
RELIABLE = QoSProfile(depth=100)
BEST_EFFORT = QoSProfile(depth=100, reliability=ReliabilityPolicy.BEST_EFFORT)
LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)


def odom(i: int) -> Odometry:
    m = Odometry()
    m.header.frame_id = 'map'
    m.child_frame_id = f'msg{i}'
    m.pose.pose.position.x = float(i)
    m.pose.covariance[0] = 0.5 * i
    return m


def pose(i: int) -> PoseWithCovarianceStamped:
    m = PoseWithCovarianceStamped()
    m.header.frame_id = f'pose{i}'
    m.pose.pose.position.y = -float(i)
    return m


def read_bag(bag: Path) -> tuple[dict[str, list[bytes]], dict]:
    """Payloads per topic (in bag order) and the connections per topic."""
    out: dict[str, list[bytes]] = {}
    with Reader(bag) as reader:
        conns = {c.topic: c for c in reader.connections}
        for conn, _, raw in reader.messages():
            out.setdefault(conn.topic, []).append(bytes(raw))
    return out, conns


def odoms(raws: list[bytes]) -> list[Odometry]:
    """Decoded: CDR alignment padding is not guaranteed to be zero, so equal messages may differ in bytes."""
    return [deserialize_message(r, Odometry) for r in raws]


def decoded_three_ways(bag: Path, topic: str) -> list[str]:
    """The ``child_frame_id`` of every Odometry on ``topic``, by rosbags, rclpy and mcap+mcap_ros2 (which agree)."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    got, _ = read_bag(bag)
    ts = get_typestore(Stores.ROS2_JAZZY)
    by_rosbags = [ts.deserialize_cdr(r, 'nav_msgs/msg/Odometry').child_frame_id for r in got.get(topic, [])]
    by_rclpy = [m.child_frame_id for m in odoms(got.get(topic, []))]
    (mcap_file,) = bag.glob('*.mcap')
    with mcap_file.open('rb') as f:
        by_mcap = [m.child_frame_id for _, ch, _, m in
                   make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages() if ch.topic == topic]
    assert by_rosbags == by_rclpy == by_mcap
    return by_rosbags


def make_recorder(ros, bag: Path, **params) -> RecorderNode:
    overrides = [Parameter('bag', value=str(bag)), Parameter('flush_period', value=0.2)]
    overrides += [Parameter(k, value=v) for k, v in params.items()]
    return ros.add(RecorderNode(context=ros.context, parameter_overrides=overrides))


def close_node(ros, node) -> None:
    """Destroy ``node`` now (the recorder closes its bag) instead of at teardown."""
    ros.executor.remove_node(node)
    ros.nodes.remove(node)
    node.destroy_node()


def embedded_distro(bag) -> str:
    """``ros_distro`` of the rosbag2 metadata record inside the bag's MCAP file."""
    from mcap.reader import make_reader

    with open(next(bag.glob('*.mcap')), 'rb') as f:
        records = [m.metadata['serialized_metadata'] for m in make_reader(f).iter_metadata() if m.name == 'rosbag2']
    assert len(records) == 1, records
    return re.search(r'ros_distro: (\S+)', records[0]).group(1)


def publish_all(ros, pub, msgs) -> list[bytes]:
    """Publish ``msgs`` once ``pub`` has a subscriber; return their serialized payloads."""
    assert ros.spin_until(lambda: pub.get_subscription_count() > 0, 10.0), 'recorder never subscribed'
    ros.spin_for(0.1)
    for m in msgs:
        pub.publish(m)
        ros.spin_for(0.005)
    return [serialize_message(m) for m in msgs]


def test_records_topics_with_their_qos_in_process(ros, tmp_path):
    node = ros.add(rclpy.create_node('pub', context=ros.context))
    pub_odom = node.create_publisher(Odometry, '/r/odom', RELIABLE)
    pub_pose = node.create_publisher(PoseWithCovarianceStamped, '/r/pose', BEST_EFFORT)
    pub_static = node.create_publisher(Odometry, '/r/static', LATCHED)
    pub_static.publish(odom(99))  # before the recorder exists: arrives through transient-local
    bag = tmp_path / 'bags' / 'inproc'
    rec = make_recorder(ros, bag, topics=['/r/odom', 'r/pose', '/r/static'])
    assert ros.spin_until(lambda: len(rec.subscriptions_by_topic) == 3, 10.0)
    sent_odom = publish_all(ros, pub_odom, [odom(i) for i in range(N)])
    sent_pose = publish_all(ros, pub_pose, [pose(i) for i in range(N)])
    want = {'/r/odom': N, '/r/pose': N, '/r/static': 1}
    assert ros.spin_until(lambda: rec.message_counts() == want, 10.0), rec.message_counts()
    close_node(ros, rec)

    assert (bag / 'metadata.yaml').is_file()
    with Reader(bag) as r:
        assert r.ros_distro == 'jazzy'  # not 'rosbags'
    assert embedded_distro(bag) == 'jazzy'  # the same inside the MCAP (what Foxglove reads)
    got, conns = read_bag(bag)
    # Decoded, not byte for byte: CDR alignment padding is not guaranteed to be zero on the wire.
    assert [deserialize_message(r, Odometry) for r in got['/r/odom']] == [
        deserialize_message(r, Odometry) for r in sent_odom]
    assert [deserialize_message(r, PoseWithCovarianceStamped) for r in got['/r/pose']] == [
        deserialize_message(r, PoseWithCovarianceStamped) for r in sent_pose]
    assert [deserialize_message(r, Odometry) for r in got['/r/static']] == [odom(99)]
    assert conns['/r/pose'].ext.offered_qos_profiles[0].reliability == QosReliability.BEST_EFFORT
    assert conns['/r/odom'].ext.offered_qos_profiles[0].reliability == QosReliability.RELIABLE
    assert conns['/r/static'].ext.offered_qos_profiles[0].durability == QosDurability.TRANSIENT_LOCAL
    # Three decoders agree: rosbags' typestore, rclpy, and mcap with the embedded schemas.
    ts = get_typestore(Stores.ROS2_JAZZY)
    assert [ts.deserialize_cdr(r, 'nav_msgs/msg/Odometry').child_frame_id for r in got['/r/odom']] == \
        [f'msg{i}' for i in range(N)]
    assert deserialize_message(got['/r/pose'][3], PoseWithCovarianceStamped) == pose(3)
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    (mcap_file,) = bag.glob('*.mcap')
    with mcap_file.open('rb') as f:
        xs = [m.pose.pose.position.x for _, ch, _, m in
              make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages() if ch.topic == '/r/odom']
    assert xs == [float(i) for i in range(N)]


def test_regex_discovers_a_topic_that_appears_later(ros, tmp_path):
    bag = tmp_path / 'bags' / 'late'
    rec = make_recorder(ros, bag, regex='^/late/')
    node = ros.add(rclpy.create_node('late_pub', context=ros.context))
    ros.spin_for(0.3)  # the recorder has polled the graph a few times, with nothing to record
    assert rec.message_counts() == {}
    pub_late = node.create_publisher(Odometry, '/late/odom', RELIABLE)
    pub_other = node.create_publisher(Odometry, '/other/odom', RELIABLE)
    sent = publish_all(ros, pub_late, [odom(i) for i in range(N)])
    for i in range(5):
        pub_other.publish(odom(i))
    assert ros.spin_until(lambda: rec.message_counts().get('/late/odom') == N, 10.0), rec.message_counts()
    ros.spin_for(0.3)
    close_node(ros, rec)
    got, _ = read_bag(bag)
    assert set(got) == {'/late/odom'}  # neither /other/odom nor /rosout, /parameter_events
    assert odoms(got['/late/odom']) == odoms(sent)


def test_a_stop_records_what_the_subscriptions_still_hold(ros, tmp_path):
    """Messages delivered to the recorder but not yet taken by the executor (a stop signal can land just
    then) are in the bag after the stop: closing drains the subscriptions."""
    node = ros.add(rclpy.create_node('held_pub', context=ros.context))
    pub = node.create_publisher(Odometry, '/held/odom', RELIABLE)
    seen = []
    node.create_subscription(Odometry, '/held/odom', seen.append, RELIABLE)
    bag = tmp_path / 'bags' / 'held'
    rec = make_recorder(ros, bag, topics=['/held/odom'])
    sent = publish_all(ros, pub, [odom(i) for i in range(3)])
    assert ros.spin_until(lambda: rec.message_counts() == {'/held/odom': 3}, 10.0)
    ros.executor.remove_node(rec)            # from now on nothing takes the recorder's messages
    held = [odom(i) for i in range(3, 8)]
    for m in held:
        pub.publish(m)
    assert ros.spin_until(lambda: len(seen) == 8, 10.0)   # delivered (to the probe on the same host)
    ros.executor.add_node(rec)
    close_node(ros, rec)
    got, _ = read_bag(bag)
    assert odoms(got['/held/odom']) == odoms(sent) + held


def test_use_sim_time_discovers_before_clock_and_stamps_with_sim_time(ros, tmp_path):
    from rosgraph_msgs.msg import Clock

    bag = tmp_path / 'bags' / 'sim'
    rec = make_recorder(ros, bag, topics=['/sim/odom'], use_sim_time=True)
    node = ros.add(rclpy.create_node('sim_pub', context=ros.context))
    pub = node.create_publisher(Odometry, '/sim/odom', RELIABLE)
    # No /clock yet: discovery must still run (a launcher starts the clock only after this).
    assert ros.spin_until(lambda: '/sim/odom' in rec.subscriptions_by_topic, 10.0)
    clock_pub = node.create_publisher(Clock, '/clock', RELIABLE)
    sim_ns = 42 * 10**9 + 5

    def clock_reached() -> bool:
        clock_pub.publish(Clock(clock=rclpy.time.Time(nanoseconds=sim_ns).to_msg()))
        return rec.get_clock().now().nanoseconds == sim_ns

    assert ros.spin_until(clock_reached, 10.0)
    sent = publish_all(ros, pub, [odom(i) for i in range(5)])
    assert ros.spin_until(lambda: rec.message_counts() == {'/sim/odom': 5}, 10.0)
    close_node(ros, rec)
    with Reader(bag) as reader:
        got = [(t, bytes(raw)) for _, t, raw in reader.messages()]
    assert got == [(sim_ns, raw) for raw in sent]


def test_by_default_a_recorder_beside_a_sim_time_run_follows_its_clock(ros, tmp_path):
    """No use_sim_time given: the bag spans the run's sim time (10 s here), not the wall time it took."""
    from rosgraph_msgs.msg import Clock

    bag = tmp_path / 'bags' / 'follows'
    rec = make_recorder(ros, bag, topics=['/run/odom'])
    node = ros.add(rclpy.create_node('run_pub', context=ros.context))
    pub = node.create_publisher(Odometry, '/run/odom', RELIABLE)
    clock_pub = node.create_publisher(Clock, '/clock', RELIABLE)
    t0 = 1_000 * 10**9

    def took(ns: int) -> bool:  # the recorder has taken this /clock value (without a clock choice: no wait)
        stamps = getattr(rec, '_stamps', None)
        return stamps is None or stamps.latest == ns

    assert ros.spin_until(lambda: '/run/odom' in rec.subscriptions_by_topic and clock_pub.get_subscription_count(),
                          30.0)
    sent = []
    for i in range(11):  # one message per sim second, as fast as the wall clock allows
        clock_pub.publish(Clock(clock=rclpy.time.Time(nanoseconds=t0 + i * 10**9).to_msg()))
        assert ros.spin_until(lambda i=i: took(t0 + i * 10**9), 10.0)
        sent += publish_all(ros, pub, [odom(i)])
        # taken before the next /clock (on a busy machine the next /clock can overtake it)
        assert ros.spin_until(lambda i=i: rec.message_counts().get('/run/odom', 0) == i + 1, 10.0)
    assert ros.spin_until(lambda: rec.message_counts() == {'/run/odom': 11}, 10.0)
    close_node(ros, rec)
    with Reader(bag) as reader:
        stamps = [t for _, t, _ in reader.messages()]
        assert reader.duration == 10 * 10**9 + 1  # rosbag2's duration: last - first + 1 ns
    assert stamps == [t0 + i * 10**9 for i in range(11)]
    assert decoded_three_ways(bag, '/run/odom') == [f'msg{i}' for i in range(11)]


def test_the_bag_notes_how_far_clock_ran_and_the_summary_tells_a_cut_run(ros, tmp_path):
    """Under use_sim_time (as ros2 launch runs it) the recorder notes the first and the last /clock value in
    metadata.yaml; ``track-summary --duration`` marks a run whose /clock stopped before it CUT and exits 1."""
    import yaml
    from rosgraph_msgs.msg import Clock

    from track_nodes.report.summary import main as summary_main

    bag = tmp_path / 'bags' / 'cut'
    rec = make_recorder(ros, bag, topics=['/cut/odom'], use_sim_time=True)
    node = ros.add(rclpy.create_node('cut_pub', context=ros.context))
    pub = node.create_publisher(Odometry, '/cut/odom', RELIABLE)
    clock_pub = node.create_publisher(Clock, '/clock', RELIABLE)
    t0 = 1_000 * 10**9
    assert ros.spin_until(lambda: '/cut/odom' in rec.subscriptions_by_topic and clock_pub.get_subscription_count(),
                          30.0)
    for i in range(16):  # 15 s of a 36 s run, then the stop reaches only the clock
        t = t0 + i * 10**9
        clock_pub.publish(Clock(clock=rclpy.time.Time(nanoseconds=t).to_msg()))
        assert ros.spin_until(lambda t=t: rec.clock_span[-1:] == [t], 10.0)
        publish_all(ros, pub, [odom(i)])
    assert ros.spin_until(lambda: rec.message_counts() == {'/cut/odom': 16}, 10.0)
    close_node(ros, rec)
    custom = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']['custom_data']
    assert custom == {'clock_first_ns': str(t0), 'clock_last_ns': str(t0 + 15 * 10**9)}
    assert summary_main([str(bag), '--duration', '36']) == 1  # cut
    assert summary_main([str(bag), '--duration', '15']) == 0  # complete
    assert summary_main([str(bag)]) == 0  # not judged


def test_discard_empty_removes_a_bag_that_holds_nothing(ros, tmp_path):
    """A refused or failed run (the launchers set discard_empty) leaves no empty bag directory behind."""
    empty = tmp_path / 'bags' / 'empty'
    close_node(ros, make_recorder(ros, empty, topics=['/nothing'], discard_empty=True))
    assert not empty.exists()
    kept = tmp_path / 'bags' / 'kept'
    close_node(ros, make_recorder(ros, kept, topics=['/nothing']))  # a plain track-record keeps it, as rosbag2
    assert (kept / 'metadata.yaml').is_file()


def test_by_default_a_recorder_without_clock_messages_stamps_wall_time(ros, tmp_path):
    """A /clock publisher that sends nothing (a wall-time launcher run) does not make it sim time."""
    import time

    from rosgraph_msgs.msg import Clock

    bag = tmp_path / 'bags' / 'wall'
    rec = make_recorder(ros, bag, topics=['/w/odom'], clock_wait=0.2)
    node = ros.add(rclpy.create_node('wall_pub', context=ros.context))
    pub = node.create_publisher(Odometry, '/w/odom', RELIABLE)
    node.create_publisher(Clock, '/clock', RELIABLE)
    before = time.time_ns()
    publish_all(ros, pub, [odom(i) for i in range(5)])
    decided = lambda: getattr(getattr(rec, '_stamps', None), 'mode', 'wall') == 'wall'  # noqa: E731
    assert ros.spin_until(lambda: decided() and rec.message_counts() == {'/w/odom': 5}, 10.0)
    close_node(ros, rec)
    after = time.time_ns()
    with Reader(bag) as reader:
        stamps = [t for _, t, _ in reader.messages()]
    assert len(stamps) == 5 and all(before <= t <= after for t in stamps), (before, stamps, after)


def test_clock_option_and_its_contradiction(ros, tmp_path):
    assert [(p.name, p.value) for p in parse_cli(['track-record', 'b', '--clock', 'sim'])] == [
        ('bag', 'b'), ('clock', 'sim')]
    with pytest.raises(ValueError, match='clock=wall contradicts use_sim_time'):
        make_recorder(ros, tmp_path / 'bags' / 'no', clock='wall', use_sim_time=True)
    with pytest.raises(ValueError, match="clock='bogus'"):
        make_recorder(ros, tmp_path / 'bags' / 'no2', clock='bogus')


@pytest.mark.parametrize('tf', [True, False])
def test_tf_topics_are_recorded_with_a_regex_unless_excluded(ros, tmp_path, tf):
    node = ros.add(rclpy.create_node('tf_pub', context=ros.context))
    pub_static = node.create_publisher(TFMessage, TF_STATIC, TF_STATIC_QOS)
    pub_static.publish(tf_message([planar_transform(0.0, 'map', 'gps', 1.0, 2.0, 0.0),
                                   planar_transform(0.0, 'map', 'dock', 3.0, 0.0, 0.0)]))  # before the recorder
    pub_tf = node.create_publisher(TFMessage, TF, TF_QOS)
    pub_odom = node.create_publisher(Odometry, '/x/odom', 10)
    rec = make_recorder(ros, tmp_path / 'tfbag', regex='^/x/', tf=tf)
    want_subs = {'/x/odom', TF, TF_STATIC} if tf else {'/x/odom'}
    assert ros.spin_until(lambda: set(rec.subscriptions_by_topic) == want_subs, 20.0), rec.subscriptions_by_topic
    if tf:
        assert ros.spin_until(lambda: pub_tf.get_subscription_count() > 0, 10.0)
    assert ros.spin_until(lambda: pub_odom.get_subscription_count() > 0, 10.0)
    ros.spin_for(0.2)
    for k in range(3):
        pub_tf.publish(tf_message([planar_transform(float(k), 'map', 'laser', float(k), 0.0, 0.0)]))
        pub_odom.publish(Odometry())
    want = {'/x/odom': 3, TF: 3, TF_STATIC: 1} if tf else {'/x/odom': 3}
    assert ros.spin_until(lambda: rec.message_counts() == want, 10.0), rec.message_counts()
    ros.spin_for(0.3)
    assert rec.message_counts() == want
    close_node(ros, rec)
    msgs, conns = read_bag(tmp_path / 'tfbag')
    assert set(conns) == set(want)
    if tf:
        static = deserialize_message(msgs[TF_STATIC][0], TFMessage)  # the late recorder got the latched one
        assert [t.child_frame_id for t in static.transforms] == ['gps', 'dock']
        assert conns[TF_STATIC].ext.offered_qos_profiles[0].durability == QosDurability.TRANSIENT_LOCAL
        assert conns[TF].msgtype == 'tf2_msgs/msg/TFMessage'


def test_cli_no_tf_sets_the_parameter():
    assert [(p.name, p.value) for p in parse_cli(['track-record', 'b', '-e', '^/x/', '--no-tf'])] == [
        ('bag', 'b'), ('regex', '^/x/'), ('tf', False)]
    assert all(p.name != 'tf' for p in parse_cli(['track-record', 'b']))


def test_refuses_to_overwrite_an_existing_bag(ros, tmp_path, prefix):
    (tmp_path / 'bags' / 'taken').mkdir(parents=True)
    proc = subprocess.run([prefix / 'lib/track_nodes/recorder', 'taken', '-t', '/x'], cwd=tmp_path, env=ros.env,
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert 'bags/taken' in lines[0] and 'exists' in lines[0]
    assert list((tmp_path / 'bags' / 'taken').iterdir()) == []


def start_recorder(ros, tmp_path: Path, prefix: Path, name: str, *extra: str) -> subprocess.Popen:
    return subprocess.Popen([prefix / 'lib/track_nodes/recorder', name, '-t', '/sig/odom', *extra], cwd=tmp_path,
                            env=ros.env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def publish_acked(ros, pub, msgs) -> list[bytes]:
    sent = publish_all(ros, pub, msgs)
    assert pub.wait_for_all_acked(Duration(seconds=10)), 'recorder did not acknowledge every message'
    return sent


@pytest.mark.parametrize('sig', [signal.SIGTERM, signal.SIGINT, signal.SIGHUP], ids=['SIGTERM', 'SIGINT', 'SIGHUP'])
def test_signal_closes_a_complete_bag(ros, tmp_path, prefix, sig):
    """SIGTERM (timeout, systemd, docker stop) and SIGHUP stop the recorder exactly like SIGINT."""
    node = ros.add(rclpy.create_node('sig_pub', context=ros.context))
    pub = node.create_publisher(Odometry, '/sig/odom', RELIABLE)
    proc = start_recorder(ros, tmp_path, prefix, 'sig')
    try:
        sent = publish_acked(ros, pub, [odom(i) for i in range(N)])
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=30)
    finally:
        proc.kill()
    assert proc.returncode == 0, err
    bag = tmp_path / 'bags' / 'sig'
    assert (bag / 'metadata.yaml').is_file(), err
    got, _ = read_bag(bag)
    assert odoms(got['/sig/odom']) == odoms(sent)  # decoded: CDR padding bytes are not guaranteed zero
    assert decoded_three_ways(bag, '/sig/odom') == [f'msg{i}' for i in range(N)]
    assert f'recorded {N} messages' in err and '/sig/odom' in err


def test_sigkill_leaves_a_recoverable_mcap(ros, tmp_path, prefix):
    node = ros.add(rclpy.create_node('kill_pub', context=ros.context))
    pub = node.create_publisher(Odometry, '/sig/odom', RELIABLE)
    proc = start_recorder(ros, tmp_path, prefix, 'killed', '--flush-period', '0.2')
    bag = tmp_path / 'bags' / 'killed'
    try:
        sent = publish_acked(ros, pub, [odom(i) for i in range(N)])
        # Wait (polling the file, not the clock) until a flush has put all of them in the file.
        assert ros.spin_until(lambda: len(read_broken_mcap(next(bag.glob('*.mcap'))).messages) >= N, 15.0)
        sent += publish_acked(ros, pub, [odom(i) for i in range(N, N + 5)])  # maybe not flushed yet
        proc.kill()
        proc.communicate(timeout=30)
    finally:
        proc.kill()
    assert not (bag / 'metadata.yaml').exists()
    # rosbags itself refuses the broken bag:
    with pytest.raises(FileNotFoundError):
        Reader(bag)

    rec = subprocess.run([prefix / 'bin/track-bag-recover', str(bag)], cwd=tmp_path, env=ros.env,
                         capture_output=True, text=True, timeout=60)
    assert rec.returncode == 0, rec.stderr
    out = tmp_path / 'bags' / 'killed-recovered'
    assert 'messages recovered' in rec.stdout and str(out) in rec.stdout
    got, _ = read_bag(out)
    with Reader(out) as r:
        assert r.ros_distro == 'jazzy'
    assert embedded_distro(out) == 'jazzy'
    recovered = got['/sig/odom']
    assert N <= len(recovered) <= len(sent)
    assert odoms(recovered) == odoms(sent[:len(recovered)])
    assert [deserialize_message(r, Odometry).child_frame_id for r in recovered] == \
        [f'msg{i}' for i in range(len(recovered))]


def test_bag_recover_bad_path_is_one_line(ros, tmp_path, prefix):
    proc = subprocess.run([prefix / 'bin/track-bag-recover', str(tmp_path / 'nope')], env=ros.env,
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2
    assert len(proc.stderr.strip().splitlines()) == 1 and str(tmp_path / 'nope') in proc.stderr
    assert 'Traceback' not in proc.stderr


# --- a full disk: one line, the bag closed with what was written, exit 2 ------------------------------------

@contextlib.contextmanager
def small_disk(where: Path, size: str):
    """A tmpfs of ``size`` mounted at ``where`` (root only: CI and this machine run the tests as root)."""
    where.mkdir()
    res = subprocess.run(['mount', '-t', 'tmpfs', '-o', f'size={size}', 'tmpfs', str(where)], capture_output=True,
                         text=True)
    if res.returncode != 0:
        pytest.skip(f'cannot mount a small tmpfs to fill: {res.stderr.strip() or res.returncode}')
    try:
        yield where
    finally:
        subprocess.run(['umount', '-l', str(where)], capture_output=True)


def big_odom(i: int) -> Odometry:
    m = odom(i)
    m.header.frame_id = 'map' + ' ' * 4000  # about 4.7 kB each: a 2 MiB disk fills within 500 messages
    return m


def test_a_full_disk_closes_the_bag_with_what_was_written_and_exits_2(ros, tmp_path, prefix):
    node = ros.add(rclpy.create_node('fill_pub', context=ros.context))
    pub = node.create_publisher(Odometry, '/full/odom', QoSProfile(depth=1000))
    with small_disk(tmp_path / 'disk', '2m') as disk:
        proc = subprocess.Popen([prefix / 'lib/track_nodes/recorder', str(disk / 'full'), '-t', '/full/odom',
                                 '--flush-period', '0.1'], env=ros.env, stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True)
        try:
            assert ros.spin_until(lambda: pub.get_subscription_count() > 0, 60.0), 'recorder never subscribed'
            sent = 0
            while proc.poll() is None and sent < 5000:  # 23 MB: far more than the disk holds
                for _ in range(20):
                    pub.publish(big_odom(sent))
                    sent += 1
                ros.spin_for(0.01)
            _, err = proc.communicate(timeout=60)
        finally:
            proc.kill()
        assert proc.returncode == 2, err
        assert 'Traceback' not in err, err
        errors = [line for line in err.splitlines() if line.startswith('[ERROR]')]
        assert len(errors) == 1, err
        assert 'No space left on device' in errors[0] and 'the bag is closed with the' in errors[0], errors[0]
        bag = disk / 'full'
        assert (bag / 'metadata.yaml').is_file()
        assert not (bag / '.disk-reserve').exists()
        ids = decoded_three_ways(bag, '/full/odom')
        assert ids == [f'msg{i}' for i in range(len(ids))] and len(ids) > 0  # a prefix of what was sent, in order
        with Reader(bag) as r:
            assert r.message_count == len(ids) and r.ros_distro == 'jazzy'
        taken = int(re.search(r'recording stopped after (\d+) messages', errors[0]).group(1))
        assert f'closed with the {len(ids)} written' in errors[0]
        assert f'{taken - len(ids)} taken after it are not in the bag' in errors[0]
        assert len(ids) <= taken <= sent


def test_no_room_for_a_bag_at_start_is_one_line_and_exit_2(ros, tmp_path, prefix):
    with small_disk(tmp_path / 'disk', '64k') as disk:
        proc = subprocess.run([prefix / 'lib/track_nodes/recorder', str(disk / 'none'), '-t', '/x'], env=ros.env,
                              capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and 'No space left on device' in lines[0] and 'none' in lines[0], proc.stderr


# --- bursts: nothing lost without a count (issue 13) --------------------------------------------------

BURSTER = """
import sys, time, rclpy
from nav_msgs.msg import Odometry
from rclpy.qos import QoSProfile, ReliabilityPolicy
n, rate, best_effort, depth = int(sys.argv[1]), float(sys.argv[2]), sys.argv[3] == '1', int(sys.argv[5])
rclpy.init()
node = rclpy.create_node('burster')
qos = QoSProfile(depth=depth, reliability=ReliabilityPolicy.BEST_EFFORT if best_effort else ReliabilityPolicy.RELIABLE)
pub = node.create_publisher(Odometry, '/burst', qos)
deadline = time.monotonic() + 60
while pub.get_subscription_count() == 0 and time.monotonic() < deadline:
    time.sleep(0.02)
time.sleep(0.5)
t0 = time.monotonic()
for i in range(n):
    m = Odometry()
    m.child_frame_id = f'msg{i}'
    pub.publish(m)
    while time.monotonic() < t0 + (i + 1) / rate:
        pass
time.sleep(float(sys.argv[4]))  # keep the writer alive while the recorder catches up
"""


def _busy_neighbour(ros, load: float) -> None:
    """A node on the recorder's executor whose callbacks hold it ``load`` of the time (as in the launcher)."""
    import time

    def hog() -> None:
        t = time.perf_counter()
        while time.perf_counter() - t < 0.05 * load:
            pass

    ros.add(rclpy.create_node('busy', context=ros.context)).create_timer(0.05, hog)


def _burst(ros, tmp_path, venv, n: int, rate: float, best_effort: bool, linger: float = 5.0, depth: int = 5000):
    rec = make_recorder(ros, tmp_path / 'burst', topics=['/burst'], warn_throttle=0.5)
    _busy_neighbour(ros, 0.8)
    proc = subprocess.Popen([str(venv / 'bin/python3'), '-c', BURSTER, str(n), str(rate), '1' if best_effort else '0',
                             str(linger), str(depth)], env=ros.env)
    return rec, proc


@pytest.mark.parametrize(('n', 'rate', 'depth'), [(5000, 2000.0, 5000), (10_000, 1e9, 10_000)],
                         ids=['5000-at-2000-per-s', '10k-back-to-back'])
def test_a_burst_from_a_reliable_publisher_with_enough_history_is_recorded_whole(ros, tmp_path, venv, n, rate,
                                                                                  depth):
    """A burst while another node holds the executor 80 % of the time: 5,000 messages at 2,000/s (the old
    recorder's queue of 100 lost about 70 % of such bursts), and 10,000 published back to back with history
    10,000 (twice the 5000 samples a Fast DDS reader holds by default)."""
    rec, proc = _burst(ros, tmp_path, venv, n, rate, best_effort=False, linger=30.0, depth=depth)
    try:
        assert ros.spin_until(lambda: rec.message_counts().get('/burst', 0) >= n, 120.0), rec.summary()
    finally:
        proc.kill()
        proc.wait()
    assert rec.losses.total() == 0
    close_node(ros, rec)
    payloads, _ = read_bag(tmp_path / 'burst')
    assert [deserialize_message(raw, Odometry).child_frame_id for raw in payloads['/burst']] == [
        f'msg{i}' for i in range(n)]

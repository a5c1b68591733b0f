"""The player: payloads and order, /clock from bag time, --rate, --topics, --start-offset, bad input."""

from __future__ import annotations

import itertools
import os
import shutil
import signal
import subprocess
from pathlib import Path

import pytest
import rclpy
from geometry_msgs.msg import PoseWithCovarianceStamped
from nav_msgs.msg import Odometry
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile
from rclpy.serialization import serialize_message
from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
from rosbags.typesys import Stores, get_typestore
from rosgraph_msgs.msg import Clock

from track_nodes.bag.player import PlayerNode, wall_offsets
from track_nodes.bag.writer import BagWriter

pytestmark = pytest.mark.integration

T0 = 1_000 * 10**9  # bag time of the first message [ns]
MS = 10**6
TOPICS = {'/p/odom': Odometry, '/p/pose': PoseWithCovarianceStamped, '/p/static': Odometry}
LATCHED = Qos(QosHistory.KEEP_LAST, 1, QosReliability.RELIABLE, QosDurability.TRANSIENT_LOCAL, QosTime(0, 0),
              QosTime(0, 0), QosLiveliness.AUTOMATIC, QosTime(0, 0), False)
SUB_QOS = QoSProfile(depth=1000)
SUB_LATCHED = QoSProfile(depth=10, durability=DurabilityPolicy.TRANSIENT_LOCAL)


def odom(i: int, t_ns: int) -> Odometry:
    m = Odometry()
    m.header.stamp.sec, m.header.stamp.nanosec = divmod(t_ns, 10**9)
    m.child_frame_id = f'odom{i}'
    m.pose.pose.position.x = float(i)
    return m


def pose(i: int) -> PoseWithCovarianceStamped:
    m = PoseWithCovarianceStamped()
    m.header.frame_id = f'pose{i}'
    m.pose.covariance[7] = float(i)
    return m


@pytest.fixture(scope='module')
def bag(tmp_path_factory) -> tuple[Path, dict[str, list[tuple[int, bytes]]]]:
    """A 0.95 s bag: /p/odom every 50 ms, /p/pose every 100 ms, one transient-local /p/static."""
    content: dict[str, list[tuple[int, bytes]]] = {
        '/p/odom': [(T0 + 50 * MS * i, serialize_message(odom(i, T0 + 50 * MS * i))) for i in range(20)],
        '/p/pose': [(T0 + 25 * MS + 100 * MS * i, serialize_message(pose(i))) for i in range(10)],
        '/p/static': [(T0, serialize_message(odom(-1, T0)))],
    }
    path = tmp_path_factory.mktemp('player') / 'bag'
    ts = get_typestore(Stores.ROS2_JAZZY)
    w = BagWriter(path).open()  # as the recorder writes it: chunks with CRCs
    conns = {
        '/p/odom': w.add_connection('/p/odom', 'nav_msgs/msg/Odometry', typestore=ts),
        '/p/pose': w.add_connection('/p/pose', 'geometry_msgs/msg/PoseWithCovarianceStamped', typestore=ts),
        '/p/static': w.add_connection('/p/static', 'nav_msgs/msg/Odometry', typestore=ts,
                                      offered_qos_profiles=[LATCHED]),
    }
    for t, topic, raw in sorted((t, topic, raw) for topic, msgs in content.items() for t, raw in msgs):
        w.write(conns[topic], t, raw)
    w.close()
    return path, content


class Sink:
    """Subscribes to the bag's topics and /clock; keeps raw payloads and clock values (ns)."""

    def __init__(self, ros, topics=TOPICS) -> None:
        self.node = ros.add(rclpy.create_node('sink', context=ros.context))
        self.got: dict[str, list[bytes]] = {t: [] for t in topics}
        self.clock: list[int] = []
        for topic, cls in topics.items():
            qos = SUB_LATCHED if topic == '/p/static' else SUB_QOS
            self.node.create_subscription(cls, topic, lambda raw, t=topic: self.got[t].append(raw), qos, raw=True)
        self.node.create_subscription(
            Clock, '/clock', lambda m: self.clock.append(m.clock.sec * 10**9 + m.clock.nanosec), SUB_QOS)

    def counts(self) -> dict[str, int]:
        return {t: len(v) for t, v in self.got.items()}


def play(ros, bag_path: Path, **params) -> PlayerNode:
    overrides = [Parameter('bag', value=str(bag_path)), *(Parameter(k, value=v) for k, v in params.items())]
    return ros.add(PlayerNode(context=ros.context, parameter_overrides=overrides))


def run_to_end(ros, player: PlayerNode, sink: Sink, want: dict[str, int]) -> None:
    assert ros.spin_until(lambda: player.done.is_set() and sink.counts() == want, 20.0), sink.counts()
    ros.spin_for(0.2)  # nothing more arrives
    assert sink.counts() == want
    assert player.exit_code == 0


def check_clock(clock: list[int], times: list[int], start: int) -> None:
    """/clock: strictly increasing bag time, from ``start`` to the last message, through every message time."""
    assert clock, 'no /clock received'
    assert all(b > a for a, b in itertools.pairwise(clock)), 'clock went backwards'
    assert clock[0] == start
    assert clock[-1] == max(times)
    assert set(times) <= set(clock)


def test_replays_every_message_in_order_with_identical_payloads(ros, bag):
    path, content = bag
    sink = Sink(ros)
    player = play(ros, path, rate=4.0)
    run_to_end(ros, player, sink, {t: len(v) for t, v in content.items()})
    for topic, msgs in content.items():
        assert sink.got[topic] == [raw for _, raw in msgs], topic
    check_clock(sink.clock, [t for msgs in content.values() for t, _ in msgs], T0)
    # QoS: transient-local only where the recorded offered QoS was.
    dur = {t: player.get_publishers_info_by_topic(t)[0].qos_profile.durability for t in TOPICS}
    assert dur == {'/p/odom': DurabilityPolicy.VOLATILE, '/p/pose': DurabilityPolicy.VOLATILE,
                   '/p/static': DurabilityPolicy.TRANSIENT_LOCAL}


def test_waits_for_a_subscribed_track_node_to_announce_itself(ros, bag):
    """A subscriber that publishes on /track/ready but has not announced yet (a TrackNode listening for
    an older twin, not spinning) gets nothing until its announcement; then the bag from its start."""
    from diagnostic_msgs.msg import DiagnosticStatus

    from track_msgs_py.records.ready import NodeReady
    from track_msgs_py.topics import READY
    from track_nodes.base.ready import READY_QOS

    path, content = bag
    sink = Sink(ros)
    ready_pub = sink.node.create_publisher(DiagnosticStatus, READY, READY_QOS)
    player = play(ros, path, rate=4.0)
    assert ros.spin_until(lambda: player.announced.unready_subscribers(list(TOPICS)) == ['/sink'], 20.0)
    ros.spin_for(1.0)  # longer than the subscriptions' settling: the player still holds back
    assert sink.counts() == {t: 0 for t in TOPICS}
    ready_pub.publish(NodeReady('/sink', 1, 'host', 1, 'test').to_msg())
    run_to_end(ros, player, sink, {t: len(v) for t, v in content.items()})
    for topic, msgs in content.items():
        assert sink.got[topic] == [raw for _, raw in msgs], topic


def test_rate_scales_wall_time_but_clock_keeps_bag_time(ros, bag):
    path, content = bag
    times = [t for msgs in content.values() for t, _ in msgs]
    # The schedule: due wall offsets shrink by the rate.
    assert wall_offsets(times, T0, 5.0) == pytest.approx([o / 5.0 for o in wall_offsets(times, T0, 1.0)])
    sink = Sink(ros)
    follower = ros.add(rclpy.create_node('follower', context=ros.context,
                                         parameter_overrides=[Parameter('use_sim_time', value=True)]))
    player = play(ros, path, rate=5.0)
    run_to_end(ros, player, sink, {t: len(v) for t, v in content.items()})
    # Played 5x faster, yet /clock still steps through the bag times with the bag's spacing...
    check_clock(sink.clock, times, T0)
    odom_times = [t for t, _ in content['/p/odom']]
    stamps = [t for t in sink.clock if t in set(odom_times)]
    assert [b - a for a, b in itertools.pairwise(stamps)] == [50 * MS] * 19
    # ...and a use_sim_time node follows bag time.
    assert ros.spin_until(lambda: follower.get_clock().now().nanoseconds == max(times), 5.0)


def test_topics_filter(ros, bag):
    path, content = bag
    sink = Sink(ros)
    player = play(ros, path, rate=4.0, topics=['/p/pose'])
    run_to_end(ros, player, sink, {'/p/odom': 0, '/p/pose': 10, '/p/static': 0})
    assert sink.got['/p/pose'] == [raw for _, raw in content['/p/pose']]
    assert set(player.publishers_by_topic) == {'/p/pose'}


def test_start_offset_skips_the_beginning(ros, bag):
    path, content = bag
    sink = Sink(ros)
    player = play(ros, path, rate=4.0, start_offset=0.5)
    start = T0 + 500 * MS
    want = {t: [raw for ts, raw in msgs if ts >= start] for t, msgs in content.items()}
    run_to_end(ros, player, sink, {t: len(v) for t, v in want.items()})
    assert sink.got == want
    assert len(want['/p/odom']) == 10 and want['/p/static'] == []
    check_clock(sink.clock, [t for msgs in content.values() for t, _ in msgs if t >= start], start)


def test_cli_plays_to_the_end_and_exits_0(ros, bag, prefix):
    path, content = bag
    sink = Sink(ros, {'/p/odom': Odometry})
    proc = subprocess.Popen([prefix / 'lib/track_nodes/player', str(path), '--rate', '10', '--topics', '/p/odom',
                             '--wait', '60'],  # discovery on a loaded machine can take seconds
                            env=ros.env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert ros.spin_until(lambda: proc.poll() is not None, 120.0)
        _, err = proc.communicate(timeout=10)
    finally:
        proc.kill()
    assert proc.returncode == 0, err
    ros.spin_until(lambda: sink.counts()['/p/odom'] == 20, 5.0)
    assert sink.got['/p/odom'] == [raw for _, raw in content['/p/odom']]  # the first one too (issue 19, item 9)


# Each maker returns (path given to the player, path the error must name, extra arguments).
def _missing(tmp: Path, bag: Path) -> tuple[Path, Path, list[str]]:
    return tmp / 'no_such_bag', tmp / 'no_such_bag', []


def _not_a_bag(tmp: Path, bag: Path) -> tuple[Path, Path, list[str]]:
    (tmp / 'notabag').mkdir()
    (tmp / 'notabag' / 'readme.txt').write_text('hello\n')
    return tmp / 'notabag', tmp / 'notabag', []


def _no_metadata(tmp: Path, bag: Path) -> tuple[Path, Path, list[str]]:
    shutil.copytree(bag, tmp / 'killed')
    (tmp / 'killed' / 'metadata.yaml').unlink()
    return tmp / 'killed', tmp / 'killed', []


def _truncated(tmp: Path, bag: Path) -> tuple[Path, Path, list[str]]:
    shutil.copytree(bag, tmp / 'cut')
    (mcap,) = (tmp / 'cut').glob('*.mcap')
    data = mcap.read_bytes()
    mcap.write_bytes(data[:len(data) // 2])
    return tmp / 'cut', mcap, []


def _cut_to(n: int):
    def make(tmp: Path, bag: Path) -> tuple[Path, Path, list[str]]:
        shutil.copytree(bag, tmp / f'cut{n}')
        (mcap,) = (tmp / f'cut{n}').glob('*.mcap')
        mcap.write_bytes(mcap.read_bytes()[:n])
        return tmp / f'cut{n}', mcap, []
    return make


def _garbage(tmp: Path, bag: Path) -> tuple[Path, Path, list[str]]:
    shutil.copytree(bag, tmp / 'garbage')
    (mcap,) = (tmp / 'garbage').glob('*.mcap')
    data = bytearray(mcap.read_bytes())
    data[8:] = bytes((i * 151 + 7) % 256 for i in range(len(data) - 8))  # magic kept, the rest noise
    mcap.write_bytes(bytes(data))
    return tmp / 'garbage', mcap, []


def _rate(value: str):
    def make(tmp: Path, bag: Path) -> tuple[Path, Path, list[str]]:
        return bag, bag, ['--rate', value]
    return make


def _flipped_bit(tmp: Path, bag: Path, flip_bit) -> tuple[Path, Path, list[str]]:
    shutil.copytree(bag, tmp / 'flipped')
    (mcap,) = (tmp / 'flipped').glob('*.mcap')
    flip_bit(mcap)
    return tmp / 'flipped', mcap, []


def _fifo(tmp: Path, bag: Path) -> tuple[Path, Path, list[str]]:
    os.mkfifo(tmp / 'fifo.mcap')
    return tmp / 'fifo.mcap', tmp / 'fifo.mcap', []


def _fifo_in_a_bag(tmp: Path, bag: Path) -> tuple[Path, Path, list[str]]:
    shutil.copytree(bag, tmp / 'piped')
    (mcap,) = (tmp / 'piped').glob('*.mcap')
    mcap.unlink()
    os.mkfifo(mcap)
    return tmp / 'piped', mcap, []


def _edited_metadata(name: str, old: str, new: str):
    """A copy of the bag whose metadata.yaml has ``old`` replaced by ``new`` (every occurrence)."""
    def make(tmp: Path, bag: Path) -> tuple[Path, Path, list[str]]:
        shutil.copytree(bag, tmp / name)
        meta = tmp / name / 'metadata.yaml'
        text = meta.read_text()
        assert old in text
        meta.write_text(text.replace(old, new))
        return tmp / name, tmp / name, []
    return make


def _past_the_end(tmp: Path, bag: Path) -> tuple[Path, Path, list[str]]:
    return bag, bag, ['--start-offset', '5']


def _past_the_topic(tmp: Path, bag: Path) -> tuple[Path, Path, list[str]]:
    return bag, bag, ['--start-offset', '0.5', '--topics', '/p/static']  # /p/static has one message at 0 s


@pytest.mark.parametrize(('make', 'problem'), [
    (_missing, 'no such bag'),
    (_not_a_bag, 'not a rosbag2 bag'),
    (_no_metadata, 'track-bag-recover'),
    (_truncated, 'truncated'),
    (_cut_to(0), 'truncated'),
    (_cut_to(8), 'truncated'),
    (_cut_to(9), 'truncated'),
    (_cut_to(40), 'truncated'),
    (_garbage, 'truncated'),
    (_rate('0'), 'rate'),
    (_rate('1e-9'), 'rate'),
    (_rate('1e9'), 'rate'),
    (_flipped_bit, 'chunk 1 at byte'),
    (_fifo, 'FIFO'),
    (_fifo_in_a_bag, 'FIFO'),
    (_edited_metadata('renamed', 'name: /p/pose', 'name: /p/posed'), 'disagree'),
    (_edited_metadata('retyped', 'type: geometry_msgs/msg/PoseWithCovarianceStamped',
                      'type: geometry_msgs/msg/PoseStamped'), 'disagree'),
    (_past_the_end, 'past the last message'),
    (_past_the_topic, 'past the last message'),
], ids=['missing', 'not-a-bag', 'no-metadata', 'truncated', 'cut-0', 'cut-8', 'cut-9', 'cut-40', 'garbage',
        'rate-0', 'rate-1e-9', 'rate-1e9', 'flipped-bit', 'fifo', 'fifo-in-a-bag',
        'metadata-topic', 'metadata-type', 'offset-past-end', 'offset-past-topic'])
def test_bad_input_is_one_line_and_exit_2(ros, bag, prefix, tmp_path, flip_bit, make, problem):
    given, named, extra = make(tmp_path, bag[0], flip_bit) if make is _flipped_bit else make(tmp_path, bag[0])
    sink = Sink(ros)
    proc = subprocess.run([prefix / 'lib/track_nodes/player', str(given), *extra], env=ros.env,
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert str(named) in lines[0] and problem in lines[0], lines[0]
    assert 'Traceback' not in proc.stderr
    ros.spin_for(0.1)
    assert sink.counts() == dict.fromkeys(TOPICS, 0) and sink.clock == []  # nothing was published


def test_a_wrong_message_count_in_metadata_is_a_warning_and_the_real_count_is_played(ros, bag, prefix, tmp_path):
    given, _, _ = _edited_metadata('miscounted', 'message_count: 20', 'message_count: 99999')(tmp_path, bag[0])
    sink = Sink(ros, {'/p/odom': Odometry})
    proc = subprocess.Popen([prefix / 'lib/track_nodes/player', str(given), '--rate', '10', '--topics', '/p/odom',
                             '--wait', '60'], env=ros.env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert ros.spin_until(lambda: proc.poll() is not None, 120.0)
        _, err = proc.communicate(timeout=10)
    finally:
        proc.kill()
    assert proc.returncode == 0, err
    warnings = [line for line in err.splitlines() if 'metadata.yaml says' in line]
    assert len(warnings) == 1 and '/p/odom: 99999 → 20' in warnings[0], err
    assert 'playing 20 messages' in err and 'played 20 messages' in err, err
    assert '99999' not in err.replace(warnings[0], ''), err  # announced nowhere else
    ros.spin_until(lambda: sink.counts()['/p/odom'] == 20, 5.0)
    assert sink.counts()['/p/odom'] == 20


@pytest.mark.parametrize('sig', [signal.SIGTERM, signal.SIGHUP], ids=['SIGTERM', 'SIGHUP'])
def test_a_stop_signal_stops_playback_like_sigint_and_says_how_much_was_played(ros, bag, prefix, sig):
    path, _ = bag
    sink = Sink(ros, {'/p/odom': Odometry})
    proc = subprocess.Popen([prefix / 'lib/track_nodes/player', str(path), '--rate', '0.02', '--topics', '/p/odom',
                             '--wait', '60'], env=ros.env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:  # 20 messages over 47.5 s of wall time: stopped after the first
        assert ros.spin_until(lambda: sink.counts()['/p/odom'] >= 1 or proc.poll() is not None, 120.0)
        assert proc.poll() is None, proc.communicate()[1]
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    assert proc.returncode == 0, err
    played = [line for line in err.splitlines() if 'played' in line]
    assert len(played) == 1 and 'of 20 messages' in played[0] and 'stopped before the end' in played[0], err
    assert 'Traceback' not in err

"""``track-foxglove``: the live graph over the Foxglove WebSocket protocol, seen by an independent client.

- In-process: the ``slam_sim`` scenario (``slam_sim`` and ``slam``: odometry, clouds, /tf and the
  latched /tf_static) and the bridge in one context; the client (``foxglove_client.py``: the
  ``websockets`` package and the protocol's own frames, not the SDK) sees every topic advertised
  with its ``ros2msg`` schema, subscribes, and decodes real messages with the advertised schema
  through ``mcap_ros2`` (what Foxglove does), equal to what rclpy deserialises from the same bytes.
- A topic that appears later (a ``track_msgs`` type: the schema comes from our type store) is
  advertised and served, and unadvertised when its publisher goes; a second client connecting late
  still gets /tf_static.
- As a process: ``--port``/``--address``, one line for a port in use, SIGINT and SIGTERM stop it
  with exit 0.
"""

from __future__ import annotations

import importlib.util
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import rclpy
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import PointCloud2
from tf2_msgs.msg import TFMessage

from track_msgs.msg import PairScoreArray
from track_msgs_py.qos import ESTIMATE_QOS
from track_msgs_py.topics import FRAME_BASE, FRAME_LASER, FRAME_LASER_TRUTH, SLAM_SCAN, SLAM_TRUTH, TF, TF_STATIC
from track_nodes.foxglove.bridge import FoxgloveBridgeNode
from track_nodes.slam.slam import SlamNode
from track_nodes.slam.slam_sim import SlamSimNode

_spec = importlib.util.spec_from_file_location('foxglove_client', Path(__file__).with_name('foxglove_client.py'))
foxglove_client = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(foxglove_client)   # a test-support module beside this file (the suite imports by path)
FoxgloveClient = foxglove_client.FoxgloveClient

pytestmark = pytest.mark.integration
LATE = '/foxglove_test/scores'
WAIT = 90.0  # [s] generous: discovery and a first message on a loaded machine


@pytest.fixture
def live(ros, repo):
    """The slam_sim scenario on wall time, the bridge on a free port, a client connected to it."""
    params = ['--ros-args', '--params-file', str(repo / 'config/slam_sim.yaml')]
    ros.add(SlamSimNode(context=ros.context, cli_args=params))
    ros.add(SlamNode(context=ros.context, cli_args=params))
    bridge = ros.add(FoxgloveBridgeNode(context=ros.context, parameter_overrides=[
        Parameter('port', value=0), Parameter('discovery_period', value=0.1), Parameter('withdraw_after', value=0.0)]))
    clients = []

    def connect() -> FoxgloveClient:
        clients.append(FoxgloveClient(f'ws://127.0.0.1:{bridge.port}'))
        return clients[-1]

    try:
        yield bridge, connect
    finally:
        for c in clients:
            c.close()


def test_every_topic_is_served_with_its_schema_and_decodes_as_foxglove_decodes_it(ros, live):
    bridge, connect = live
    client = connect()
    topics = (SLAM_TRUTH, SLAM_SCAN, TF, TF_STATIC)
    assert ros.spin_until(lambda: client.advertised(*topics), timeout=WAIT), sorted(client.channels)
    assert client.subprotocol == 'foxglove.sdk.v1'  # the SDK's name for the v1 protocol (foxglove_client.py)
    assert client.server_info['name'] == bridge.get_fully_qualified_name()
    assert 'cdr' in client.server_info.get('supportedEncodings', [])
    for topic, name in ((SLAM_TRUTH, 'nav_msgs/msg/Odometry'), (SLAM_SCAN, 'sensor_msgs/msg/PointCloud2'),
                        (TF, 'tf2_msgs/msg/TFMessage'), (TF_STATIC, 'tf2_msgs/msg/TFMessage')):
        ch = client.channels[topic]
        assert (ch['encoding'], ch['schemaEncoding'], ch['schemaName']) == ('cdr', 'ros2msg', name), ch
    # the full definition with its dependencies, as MCAP and Foxglove expect it
    odom_schema = client.channels[SLAM_TRUTH]['schema']
    for dep in ('MSG: std_msgs/Header', 'MSG: geometry_msgs/PoseWithCovariance', 'MSG: builtin_interfaces/Time'):
        assert dep in odom_schema, dep
    assert not bridge.subscriptions_by_topic  # nothing is subscribed before a client asks

    client.subscribe(*topics)
    assert ros.spin_until(lambda: client.received(*topics), timeout=WAIT), \
        {t: len(client.messages.get(t, ())) for t in topics}

    truth = client.decode(SLAM_TRUTH)
    assert truth.header.frame_id == 'map' and truth.child_frame_id == FRAME_LASER_TRUTH
    ref = deserialize_message(client.payload(SLAM_TRUTH), Odometry)  # the raw CDR, as published
    assert (truth.pose.pose.position.x, truth.pose.pose.position.y) == (ref.pose.pose.position.x,
                                                                        ref.pose.pose.position.y)
    assert truth.header.stamp.sec == ref.header.stamp.sec and truth.header.stamp.nanosec == ref.header.stamp.nanosec
    scan = client.decode(SLAM_SCAN)
    assert [f.name for f in scan.fields[:3]] == ['x', 'y', 'z'] and scan.header.frame_id == FRAME_LASER
    assert bytes(scan.data) == bytes(deserialize_message(client.payload(SLAM_SCAN), PointCloud2).data)
    # /tf: slam_sim places laser_truth, slam map -> odom and (raw ACFR inputs, publish_odom_tf) odom -> base_link
    assert ros.spin_until(lambda: any(t.child_frame_id == FRAME_LASER_TRUTH for i in range(len(client.messages[TF]))
                                      for t in client.decode(TF, i).transforms), timeout=WAIT)
    pairs = {(t.header.frame_id, t.child_frame_id) for i in range(len(client.messages[TF]))
             for t in client.decode(TF, i).transforms}
    assert ('map', FRAME_LASER_TRUTH) in pairs and pairs <= {('map', FRAME_LASER_TRUTH), ('map', 'odom'),
                                                             ('odom', FRAME_BASE)}, pairs
    static = client.decode(TF_STATIC)
    assert (FRAME_BASE, FRAME_LASER) in {(t.header.frame_id, t.child_frame_id) for t in static.transforms}
    assert deserialize_message(client.payload(TF_STATIC), TFMessage).transforms[0].child_frame_id == FRAME_LASER
    # log times are the node's clock (wall time here), increasing
    stamps = [t for t, _ in client.messages[SLAM_TRUTH]]
    assert stamps == sorted(stamps) and abs(stamps[-1] - time.time_ns()) < 60e9


def test_a_topic_that_appears_later_is_advertised_served_and_withdrawn(ros, live):
    bridge, connect = live
    client = connect()
    assert ros.spin_until(lambda: client.advertised(SLAM_TRUTH), timeout=WAIT)
    late = ros.add(Node('late_publisher', context=ros.context))
    pub = late.create_publisher(PairScoreArray, LATE, ESTIMATE_QOS)
    assert ros.spin_until(lambda: client.advertised(LATE), timeout=WAIT), sorted(client.channels)
    ch = client.channels[LATE]
    assert ch['schemaName'] == 'track_msgs/msg/PairScoreArray' and 'MSG: track_msgs/PairScore' in ch['schema']
    client.subscribe(LATE)
    msg = PairScoreArray()
    msg.header.frame_id = 'map'
    msg.method = 'exact'

    def published() -> bool:
        pub.publish(msg)
        return client.received(LATE)

    assert ros.spin_until(published, timeout=WAIT)
    got = client.decode(LATE)
    assert (got.header.frame_id, got.method) == ('map', 'exact')
    late.destroy_publisher(pub)
    assert ros.spin_until(lambda: LATE in client.unadvertised, timeout=WAIT)
    assert LATE not in bridge.channels and LATE not in bridge.subscriptions_by_topic

    # a client connecting later still gets the latched /tf_static (a new reader per client subscription)
    second = connect()
    assert ros.spin_until(lambda: second.advertised(TF_STATIC), timeout=WAIT)
    second.subscribe(TF_STATIC)
    assert ros.spin_until(lambda: second.received(TF_STATIC), timeout=WAIT)
    assert FRAME_LASER in {t.child_frame_id for t in second.decode(TF_STATIC).transforms}   # slam's base_link -> laser


def test_under_sim_time_log_times_are_clock_s_and_the_time_is_broadcast(ros):
    from rosgraph_msgs.msg import Clock

    from track_msgs_py.qos import CLOCK_QOS

    bridge = ros.add(FoxgloveBridgeNode(context=ros.context, parameter_overrides=[
        Parameter('port', value=0), Parameter('discovery_period', value=0.1), Parameter('use_sim_time', value=True)]))
    clock = ros.add(Node('clock', context=ros.context))
    pub = clock.create_publisher(Clock, '/clock', CLOCK_QOS)
    client = FoxgloveClient(f'ws://127.0.0.1:{bridge.port}')
    try:
        assert ros.spin_until(lambda: client.advertised('/clock'), timeout=WAIT)
        assert 'time' in client.server_info['capabilities']
        client.subscribe('/clock')
        t = [1_700_000_000]

        def tick() -> bool:
            t[0] += 1
            msg = Clock()
            msg.clock.sec = t[0]
            pub.publish(msg)
            return client.received('/clock', n=3) and len(client.times) >= 3

        assert ros.spin_until(tick, timeout=WAIT)
        first = 1_700_000_001 * 10**9
        assert all(first <= ns <= t[0] * 10**9 for ns in client.times), client.times  # the broadcast time is /clock's
        log = [lt for lt, _ in client.messages['/clock']]
        # /clock's time (not the wall time, years later); 0 while the node's clock has had no /clock yet
        assert max(log) >= first and all(lt == 0 or first <= lt <= t[0] * 10**9 for lt in log), log
    finally:
        client.close()


RESTARTS = 20
BACK = '/foxglove_test/restarted'


def test_a_publisher_restarted_20_times_keeps_its_channel_and_every_subscription_receives(ros):
    """A node that stops and comes back (here a participant of its own, as another process is) keeps its
    channel id: the client's one subscription receives after every restart, the client never sees the topic
    withdrawn or advertised again, and the server never answers "Unknown channel"."""
    from rclpy.context import Context
    from std_msgs.msg import String

    bridge = ros.add(FoxgloveBridgeNode(context=ros.context, parameter_overrides=[
        Parameter('port', value=0), Parameter('discovery_period', value=0.1)]))
    client = FoxgloveClient(f'ws://127.0.0.1:{bridge.port}')
    other = Context()
    rclpy.init(context=other, domain_id=ros.domain_id)
    try:
        for k in range(RESTARTS):
            node = Node('restarted', context=other)
            pub = node.create_publisher(String, BACK, ESTIMATE_QOS)
            if k == 0:
                assert ros.spin_until(lambda: client.advertised(BACK), timeout=WAIT)
                client.subscribe(BACK)
                client.follow = frozenset({BACK})  # from now on, as Foxglove: subscribe to what is advertised again

            def received(k=k, pub=pub) -> bool:  # this publisher's message, not a late one of the one before
                pub.publish(String(data=str(k)))
                with client.lock:
                    payloads = [payload for _, payload in client.messages.get(BACK, ())]
                return str(k) in {deserialize_message(payload, String).data for payload in payloads}

            assert ros.spin_until(received, timeout=WAIT), (
                f'restart {k}: nothing received (bridge subscribed: {BACK in bridge.subscriptions_by_topic}, '
                f'forwarded {bridge.forwarded.get(BACK)}, gone {BACK in bridge.gone}, {client.statuses})')
            node.destroy_node()
            # gone for the bridge too: a graph poll has seen no publisher (before: it withdrew the channel)
            assert ros.spin_until(lambda k=k: not bridge.count_publishers(BACK) and (
                BACK in getattr(bridge, 'gone', ()) or client.unadvertised.count(BACK) > k), timeout=WAIT), k
        assert client.error is None, client.error
        assert not [m for m in client.statuses if 'Unknown channel' in m.get('message', '')], client.statuses
        assert [a for a in client.advertisements if a[0] == BACK] == [(BACK, client.channels[BACK]['id'])]
        assert BACK not in client.unadvertised
        got = {deserialize_message(payload, String).data for _, payload in client.messages[BACK]}
        assert got == {str(k) for k in range(RESTARTS)}, got  # from every one of the restarted publishers
    finally:
        client.close()
        other.try_shutdown()


def test_a_bridge_beside_a_clock_follows_it_by_default(ros):
    """clock auto (the default, no use_sim_time): the time capability; the wall time is broadcast until /clock
    is published, then /clock's time is broadcast and is every log time."""
    from rosgraph_msgs.msg import Clock

    from track_msgs_py.qos import CLOCK_QOS

    bridge = ros.add(FoxgloveBridgeNode(context=ros.context, parameter_overrides=[
        Parameter('port', value=0), Parameter('discovery_period', value=0.1)]))
    assert bridge.get_parameter('use_sim_time').value is False
    client = FoxgloveClient(f'ws://127.0.0.1:{bridge.port}')
    try:
        assert ros.spin_until(lambda: client.server_info is not None and client.times, timeout=WAIT)
        assert 'time' in client.server_info['capabilities']
        assert abs(client.times[-1] - time.time_ns()) < 60e9  # no /clock yet: the wall time
        clock = ros.add(Node('clock', context=ros.context))
        pub = clock.create_publisher(Clock, '/clock', CLOCK_QOS)
        assert ros.spin_until(lambda: client.advertised('/clock'), timeout=WAIT)
        client.subscribe('/clock')
        first = 1_700_000_001 * 10**9
        t = [1_700_000_000]

        def tick() -> bool:
            t[0] += 1
            msg = Clock()
            msg.clock.sec = t[0]
            pub.publish(msg)
            return client.received('/clock', n=3) and sum(first <= ns <= t[0] * 10**9 for ns in client.times) >= 3

        assert ros.spin_until(tick, timeout=WAIT)
        assert bridge.following
        log = [lt for lt, _ in client.messages['/clock']]
        assert all(first <= lt <= t[0] * 10**9 for lt in log), log  # /clock's time, not the wall time
    finally:
        client.close()


def test_clock_wall_advertises_no_time(ros):
    bridge = ros.add(FoxgloveBridgeNode(context=ros.context, parameter_overrides=[
        Parameter('port', value=0), Parameter('clock', value='wall')]))
    client = FoxgloveClient(f'ws://127.0.0.1:{bridge.port}')
    try:
        assert ros.spin_until(lambda: client.server_info is not None, timeout=WAIT)
        assert 'time' not in client.server_info.get('capabilities', [])
    finally:
        client.close()


def test_an_older_client_is_refused_in_words_and_a_close_frame_is_answered(ros):
    """A client offering only foxglove.websocket.v1 (or nothing) gets HTTP 400 with a line that says what it
    offered and what the server speaks, and the bridge logs it; a client that closes gets the close handshake
    (1000), not a dropped connection (1006)."""
    from websockets.exceptions import InvalidStatus
    from websockets.sync.client import connect

    bridge = ros.add(FoxgloveBridgeNode(context=ros.context, parameter_overrides=[Parameter('port', value=0)]))
    url = f'ws://127.0.0.1:{bridge.port}'
    for offered, said in ((['foxglove.websocket.v1'], 'offered foxglove.websocket.v1'),
                          (None, 'offered no subprotocol')):
        with pytest.raises(InvalidStatus) as refused:
            connect(url, subprotocols=offered, open_timeout=WAIT)
        body = bytes(refused.value.response.body).decode()
        assert refused.value.response.status_code == 400, body
        assert said in body and 'speaks foxglove.sdk.v1' in body and 'Missing expected' not in body, body
        assert len(body.strip().splitlines()) == 1, body
    assert bridge.refusals == 2
    client = FoxgloveClient(url)
    assert ros.spin_until(lambda: client.server_info is not None, timeout=WAIT)
    client._stop.set()
    client.ws.close()  # our close frame; the server's answer completes the handshake
    assert client.ws.close_code == 1000 and client.ws.protocol.close_rcvd is not None, client.ws.close_code
    client.close()


def _start(args: list[str], env: dict) -> tuple[subprocess.Popen, int]:
    """The bridge as its own process on a free port; → the process and the port it logged."""
    proc = subprocess.Popen([sys.executable, '-m', 'track_nodes', 'foxglove_bridge', '--port', '0', *args],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + WAIT
    while time.monotonic() < deadline:
        line = proc.stderr.readline()
        if m := re.search(r'on ws://127\.0\.0\.1:(\d+)', line):
            return proc, int(m.group(1))
        if not line and proc.poll() is not None:
            break
    proc.kill()
    pytest.fail(f'no serving line: {proc.communicate()}')


@pytest.mark.parametrize('sig', [signal.SIGINT, signal.SIGTERM])
def test_the_process_serves_and_stops_cleanly(sig, env_factory):
    env = env_factory()
    proc, port = _start([], env)
    try:
        client = FoxgloveClient(f'ws://127.0.0.1:{port}')
        deadline = time.monotonic() + WAIT
        while client.server_info is None and time.monotonic() < deadline:
            time.sleep(0.05)
        assert client.server_info['name'] == '/foxglove_bridge'
        # a second bridge on the same port: one line, exit 2, no traceback
        busy = subprocess.run([sys.executable, '-m', 'track_nodes', 'foxglove_bridge', '--port', str(port)],
                              env=env, capture_output=True, text=True, timeout=WAIT)
        assert busy.returncode == 2, busy.stderr
        assert f'cannot serve on 127.0.0.1:{port}' in busy.stderr and 'Traceback' not in busy.stderr
        client.close()
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=WAIT)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, err
    assert 'Traceback' not in err and 'stopped: forwarded' in err

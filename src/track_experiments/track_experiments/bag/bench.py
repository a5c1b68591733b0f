"""``track-bench recorder``: messages per second through the recorder node, against the rclpy ceiling.

Consumers take the same stream in the same run, each in its own rclpy context (own
ROS_DOMAIN_ID, localhost-only discovery) with the publisher node:

- the recorder (``RecorderNode``) on the executor it runs on (``run_node`` spins the global
  ``SingleThreadedExecutor``; it takes what is queued behind each delivery itself, ``bag.batching``),
  stamping with wall time: what ``clock: auto`` settles on without /clock (while auto is undecided,
  the first ``clock_wait`` seconds, it only holds messages, which would time no writing at all);
- the ceiling: a bare rclpy raw subscription (``raw=True``, same topic, same serialized
  ``nav_msgs/Odometry``, the recorder's subscription QoS from ``recording_qos``) whose callback only
  counts, on the ``EventsExecutor`` (``rclpy.experimental``), the fastest rclpy delivers messages
  to Python. The same subscription on the ``SingleThreadedExecutor`` (and, in the full run, the
  ``MultiThreadedExecutor``) is timed too, on fewer bursts: both collapse under a burst (a pass of
  the executor per message), so they bound nothing;
- the rosbags ``Writer`` alone writing the same payloads (no DDS, no executor).

The stream (``Stream``): bursts of ``BURST`` messages from a reliable publisher (keep-last 100) are
published while the executor is idle, then the executor drains them; the drain time is what is measured
(a 1 ms watcher timer notices when the count is complete; the recorder counts a message once it is
in the MCAP writer), since a publisher publishing while the consumer spins is GIL-bound to the
consumer's rate. ``BURST`` is 5000: Fast DDS holds at most 5000 samples per reader by default.

Reported: the rates; messages lost (published - in the closed bag, must be 0) and the losses the
recorder itself counted; the headline ``recorder_vs_events_executor_subscription``, then
``recorder_vs_rclpy_ceiling`` (the SingleThreadedExecutor subscription) and ``recorder_vs_writer``:
each the median over the runs of that run's ratio. In each run the recorder and the EventsExecutor
ceiling stand side by side (topics of their own) and take turns burst for burst (ABBA), so a
neighbour's load hits both sides of a ratio alike. Timing lives here only, never in the tests.
"""

from __future__ import annotations

import os
import shutil
import statistics
import tempfile
import time
from pathlib import Path

from track_experiments.cli import Outcome, RunConfig, format_table

TOPIC = '/bench/odom'
N_PAYLOADS = 1000
BURST = 5000  # Fast DDS's default max_samples per reader
STALL = 2.0  # wall seconds without a new message = the consumer stopped
EXECUTORS = ('single', 'events', 'multi')
SLOW_ROUNDS = 2  # bursts for the executors that collapse (about 5k/s and 1.5k/s: seconds per burst)


def _payloads() -> list[bytes]:
    from nav_msgs.msg import Odometry
    from rclpy.serialization import serialize_message

    out = []
    for i in range(N_PAYLOADS):
        m = Odometry()
        m.header.frame_id = 'map'
        m.child_frame_id = f'track{i % 7}'
        m.header.stamp.sec, m.header.stamp.nanosec = i // 100, (i % 100) * 10_000_000
        m.pose.pose.position.x = float(i)
        m.pose.covariance = [float(k) for k in range(36)]
        m.twist.covariance = [float(-k) for k in range(36)]
        out.append(serialize_message(m))
    return out


def _domain_id() -> int:
    return 200 + os.getpid() % 31  # 200..230: manual runs, away from the tests' 1..100 and others' 101..199


def _executor(kind: str, context):
    from rclpy.executors import MultiThreadedExecutor, SingleThreadedExecutor

    if kind == 'events':
        from rclpy.experimental import EventsExecutor

        return EventsExecutor(context=context)
    return {'single': SingleThreadedExecutor, 'multi': MultiThreadedExecutor}[kind](context=context)


def _ceiling_node(context, qos, topic: str):
    """A bare node with one raw subscription whose callback only counts; → (node, count())."""
    import rclpy
    from nav_msgs.msg import Odometry

    node = rclpy.create_node('bench_ceiling', context=context)
    received = [0]

    def count_one(_data: bytes) -> None:
        received[0] += 1

    node.create_subscription(Odometry, topic, count_one, qos, raw=True)
    return node, lambda: received[0]


def _recorder_node(context, bag: Path, topic: str):
    from rclpy.parameter import Parameter

    from track_nodes.bag.recorder import RecorderNode

    node = RecorderNode(context=context, parameter_overrides=[
        Parameter('bag', value=str(bag)), Parameter('topics', value=[topic]), Parameter('clock', value='wall')])
    return node, lambda: node.message_counts().get(topic, 0)


def _in_bag(bag: Path) -> int:
    """Messages in the closed bag, as a reader sees them."""
    from rosbags.rosbag2 import Reader

    with Reader(bag) as reader:
        return sum(1 for _ in reader.messages())


class Stream:
    """A publisher and one consumer ('recorder' or 'ceiling') on ``executor_kind``, in a context of their own,
    on ``topic``; ``burst()`` publishes ``BURST`` messages while the executor is idle and times the drain."""

    def __init__(self, consumer: str, executor_kind: str, payloads: list[bytes], bag: Path, topic: str = TOPIC):
        import rclpy
        from nav_msgs.msg import Odometry
        from rclpy.clock import Clock, ClockType
        from rclpy.context import Context
        from rclpy.qos import QoSProfile

        from track_nodes.bag.api import recording_qos

        os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
        os.environ.pop('ROS_LOCALHOST_ONLY', None)
        self.consumer, self.payloads, self.bag = consumer, payloads, bag
        self.published, self.seconds, self.node, self.result = 0, 0.0, None, None
        self.context = Context()
        rclpy.init(context=self.context, domain_id=_domain_id())
        self.executor = _executor(executor_kind, self.context)
        self.pub_node = rclpy.create_node(f'bench_publisher_{consumer}', context=self.context)
        try:
            pub_qos = QoSProfile(depth=100)
            self.pub = self.pub_node.create_publisher(Odometry, topic, pub_qos)
            self.node, self.count = (_recorder_node(self.context, bag, topic) if consumer == 'recorder'
                                     else _ceiling_node(self.context, recording_qos([pub_qos]), topic))
            self.executor.add_node(self.node)
            self.executor.add_node(self.pub_node)
            deadline = time.monotonic() + 15.0
            while self.pub.get_subscription_count() == 0:
                if time.monotonic() > deadline:
                    raise OSError(f'{consumer} did not subscribe within 15 s (DDS discovery failed?)')
                self.executor.spin_once(timeout_sec=0.01)
            settle = time.monotonic() + 0.3
            while time.monotonic() < settle:
                self.executor.spin_once(timeout_sec=0.01)
            self.state: dict = {}
            self.pub_node.create_timer(0.001, self._watch, clock=Clock(clock_type=ClockType.STEADY_TIME))
        except BaseException:
            self.close()
            raise

    def _watch(self) -> None:
        state = self.state
        if not state:
            return
        n, now = self.count(), time.perf_counter()
        if n != state['last']:
            state['last'], state['t_last'] = n, now
        if (n >= state['want'] or now - state['t_last'] > STALL) and not state['done'].done():
            state['done'].set_result(n)

    def burst(self) -> None:
        from rclpy.task import Future

        before = self.count()
        for i in range(BURST):
            self.pub.publish(self.payloads[(self.published + i) % len(self.payloads)])
        self.published += BURST
        t0 = time.perf_counter()
        self.state.update(want=before + BURST, last=before, t_last=t0, done=Future())
        self.executor.spin_until_future_complete(self.state['done'], timeout_sec=120.0)
        self.seconds += self.state['t_last'] - t0
        self.state.clear()

    def close(self) -> dict:
        """Tear down (the recorder closes its bag); → published, received, lost, rate, seconds. Idempotent."""
        if self.result is not None:
            return self.result
        received = self.count() if self.node is not None else 0
        self.executor.shutdown()
        if self.node is not None:
            self.node.destroy_node()
        self.pub_node.destroy_node()
        self.context.try_shutdown()
        out = {'published': self.published, 'received': received, 'lost': self.published - received,
               'rate': received / self.seconds if self.seconds > 0 else 0.0, 'seconds': self.seconds}
        if self.consumer == 'recorder' and self.node is not None:
            out['in_bag'] = _in_bag(self.bag)
            out['lost'] = self.published - min(received, out['in_bag'])
            out['counted_lost'] = self.node.losses.total()
        self.result = out
        return out


def run_stream(consumer: str, executor_kind: str, payloads: list[bytes], rounds: int, bag: Path) -> dict:
    """``rounds`` bursts of ``BURST`` messages into ``consumer`` ('recorder' or 'ceiling'); count and time."""
    stream = Stream(consumer, executor_kind, payloads, bag)
    try:
        for _ in range(rounds):
            stream.burst()
    finally:
        out = stream.close()
    return out


def run_pair(payloads: list[bytes], rounds: int, bag: Path) -> dict:
    """The recorder and the EventsExecutor ceiling side by side, burst for burst (ABBA), on topics of their own."""
    streams: dict[str, Stream] = {}
    try:
        streams['ceiling_events'] = Stream('ceiling', 'events', payloads, bag, f'{TOPIC}_ceiling')
        streams['recorder'] = Stream('recorder', 'single', payloads, bag, TOPIC)
        order = list(streams.values())
        for i in range(rounds):
            for stream in order if i % 2 == 0 else order[::-1]:
                stream.burst()
    finally:
        out = {key: stream.close() for key, stream in streams.items()}
    return out


def run_writer(payloads: list[bytes], count: int, path: Path) -> float:
    """Seconds for the rosbags Writer alone to write ``count`` of the payloads (open to close)."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_JAZZY)
    n = len(payloads)
    t0 = time.perf_counter()
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        conn = w.add_connection(TOPIC, 'nav_msgs/msg/Odometry', typestore=ts)
        for i in range(count):
            w.write(conn, 1_000_000 * i, payloads[i % n])
    return time.perf_counter() - t0


def recorder_benchmark(cfg: RunConfig) -> Outcome:
    rounds = 2 if cfg.quick else 10
    slow = min(rounds, SLOW_ROUNDS)
    runs = cfg.n_runs(full=5, quick=1)
    others = ('single',) if cfg.quick else ('single', 'multi')
    payloads = _payloads()
    workdir = Path(tempfile.mkdtemp(prefix='bench_recorder_'))
    results = []
    try:
        for r in cfg.progress(range(runs), desc='recorder', unit='run'):
            res = run_pair(payloads, rounds, workdir / f'rec{r}')
            for kind in others:
                res[f'ceiling_{kind}'] = run_stream('ceiling', kind, payloads, slow, workdir)
            count = rounds * BURST
            res['writer'] = {'rate': count / run_writer(payloads, count, workdir / f'writer{r}')}
            results.append(res)
    finally:
        shutil.rmtree(workdir, ignore_errors=True)
    rate = {k: statistics.median(x[k]['rate'] for x in results) for k in results[0]}

    def ratio(key: str) -> float:
        return statistics.median(x['recorder']['rate'] / x[key]['rate'] for x in results)

    vs_events, vs_single, vs_writer = ratio('ceiling_events'), ratio('ceiling_single'), ratio('writer')
    spread = [x['recorder']['rate'] / x['ceiling_events']['rate'] for x in results]
    lost = max(x['recorder']['lost'] for x in results)
    counted = max(x['recorder']['counted_lost'] for x in results)
    names = {'single': 'SingleThreadedExecutor', 'multi': 'MultiThreadedExecutor'}
    rows = [['recorder node (SingleThreadedExecutor, takes its queue)', rate['recorder'], lost, counted],
            ['ceiling: bare raw subscription (EventsExecutor)', rate['ceiling_events'],
             max(x['ceiling_events']['lost'] for x in results), '']]
    rows += [[f'bare raw subscription ({names[k]}, {slow} bursts)', rate[f'ceiling_{k}'],
              max(x[f'ceiling_{k}']['lost'] for x in results), ''] for k in others]
    rows += [['rosbags Writer alone', rate['writer'], '', ''],
             ['recorder / ceiling (EventsExecutor subscription)', vs_events, '', ''],
             ['recorder / SingleThreadedExecutor subscription', vs_single, '', ''],
             ['recorder / Writer', vs_writer, '', '']]
    size = len(payloads[0])
    table = format_table(['path', 'msgs/s', 'lost', 'counted lost'], rows)
    table += (f'\nnav_msgs/Odometry, {size} B CDR each; per run {rounds} bursts of {BURST} (reliable, keep-last 100 '
              f'publisher), {runs} run(s), medians (recorder / ceiling per run: {min(spread):.2f} to '
              f'{max(spread):.2f}); lost = published - in the bag (ceilings: - received); counted lost = the '
              'recorder\'s own count')
    data = {'message_bytes': size, 'burst': BURST, 'rounds': rounds, 'slow_rounds': slow, 'per_run': results,
            'recorder_msgs_per_s': rate['recorder'], 'rclpy_events_executor_msgs_per_s': rate['ceiling_events'],
            'rclpy_ceiling_msgs_per_s': rate['ceiling_single'], 'writer_msgs_per_s': rate['writer'],
            **{f'rclpy_{k}_executor_msgs_per_s': rate[f'ceiling_{k}'] for k in others},
            'recorder_vs_events_executor_subscription': vs_events,
            'recorder_vs_events_executor_subscription_per_run': spread,
            'recorder_vs_rclpy_ceiling': vs_single, 'recorder_vs_writer': vs_writer,
            'recorder_lost': lost, 'recorder_counted_lost': counted}
    return Outcome(table=table, data=data)

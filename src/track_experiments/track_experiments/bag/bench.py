"""``track-bench recorder``: messages per second through the recorder node, against two ceilings.

Three consumers take the same stream in the same run, each in its own rclpy context (own
ROS_DOMAIN_ID, localhost-only discovery) with the publisher node:

- the recorder (``RecorderNode``) on the executor kind it runs on by default
  (``SingleThreadedExecutor``: ``run_node`` spins the global executor);
- the fair ceiling: a bare rclpy raw subscription (``raw=True``, same topic, same serialized
  ``nav_msgs/Odometry``, the recorder's subscription QoS from ``recording_qos``) whose callback
  only counts, on the same executor kind;
- the rosbags ``Writer`` alone writing the same payloads (no DDS, no executor).

The stream: bursts of ``BURST`` messages from a reliable publisher (keep-last 100) are published
while the executor is idle, then the executor drains them; the drain time is what is measured
(a watcher timer, every millisecond, notices when the count is complete). A same-process
publisher publishing while the consumer spins is limited by the GIL to about the consumer's own
rate (measured: 8.7k/s published, both consumers kept up), which would measure the publisher.
``BURST`` is 5000: Fast DDS holds at most 5000 samples per reader by default (``max_samples``;
a reader given 20,000 at once kept 5000), so a longer burst would only measure that limit.

Reported: the rates, messages lost (published - recorded, must be 0), ``recorder_vs_rclpy_ceiling``
and ``recorder_vs_writer`` (median over the runs of each run's ratio: the runs interleave, so a
neighbour's load hits both sides of a ratio alike). ``--quick`` also times the ceiling on the
``EventsExecutor`` (``rclpy.experimental``); the full run adds the ``MultiThreadedExecutor``.
Timing lives here only, never in the tests.
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


def _ceiling_node(context, qos):
    """A bare node with one raw subscription whose callback only counts; → (node, count())."""
    import rclpy
    from nav_msgs.msg import Odometry

    node = rclpy.create_node('bench_ceiling', context=context)
    received = [0]

    def count_one(_data: bytes) -> None:
        received[0] += 1

    node.create_subscription(Odometry, TOPIC, count_one, qos, raw=True)
    return node, lambda: received[0]


def _recorder_node(context, bag: Path):
    from rclpy.parameter import Parameter

    from track_nodes.bag.recorder import RecorderNode

    node = RecorderNode(context=context, parameter_overrides=[
        Parameter('bag', value=str(bag)), Parameter('topics', value=[TOPIC])])
    return node, lambda: node.message_counts().get(TOPIC, 0)


def run_stream(consumer: str, executor_kind: str, payloads: list[bytes], rounds: int, bag: Path) -> dict:
    """``rounds`` bursts of ``BURST`` messages into ``consumer`` ('recorder' or 'ceiling'); count and time."""
    import rclpy
    from nav_msgs.msg import Odometry
    from rclpy.context import Context
    from rclpy.qos import QoSProfile

    from track_nodes.bag.api import recording_qos

    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    os.environ.pop('ROS_LOCALHOST_ONLY', None)
    context = Context()
    rclpy.init(context=context, domain_id=_domain_id())
    executor = _executor(executor_kind, context)
    pub_node = rclpy.create_node('bench_publisher', context=context)
    node = None
    try:
        pub_qos = QoSProfile(depth=100)
        pub = pub_node.create_publisher(Odometry, TOPIC, pub_qos)
        node, count = (_recorder_node(context, bag) if consumer == 'recorder'
                       else _ceiling_node(context, recording_qos([pub_qos])))
        executor.add_node(node)
        executor.add_node(pub_node)
        deadline = time.monotonic() + 15.0
        while pub.get_subscription_count() == 0:
            if time.monotonic() > deadline:
                raise OSError(f'{consumer} did not subscribe within 15 s (DDS discovery failed?)')
            executor.spin_once(timeout_sec=0.01)
        settle = time.monotonic() + 0.3
        while time.monotonic() < settle:
            executor.spin_once(timeout_sec=0.01)
        published, seconds = _time_bursts(executor, pub_node, pub, count, payloads, rounds)
        received = count()
    finally:
        executor.shutdown()
        if node is not None:
            node.destroy_node()  # the recorder closes its bag
        pub_node.destroy_node()
        context.try_shutdown()
    return {'published': published, 'received': received, 'lost': published - received,
            'rate': received / seconds if seconds > 0 else 0.0, 'seconds': seconds}


def _time_bursts(executor, pub_node, pub, count, payloads: list[bytes], rounds: int) -> tuple[int, float]:
    """Publish ``rounds`` bursts while the executor is idle, spin until each is drained; → (published, s)."""
    from rclpy.clock import Clock, ClockType
    from rclpy.task import Future

    state: dict = {}

    def watch() -> None:
        n, now = count(), time.perf_counter()
        if n != state['last']:
            state['last'], state['t_last'] = n, now
        if (n >= state['want'] or now - state['t_last'] > STALL) and not state['done'].done():
            state['done'].set_result(n)

    pub_node.create_timer(0.001, watch, clock=Clock(clock_type=ClockType.STEADY_TIME))
    published, seconds = 0, 0.0
    for _ in range(rounds):
        before = count()
        for i in range(BURST):
            pub.publish(payloads[(published + i) % len(payloads)])
        published += BURST
        t0 = time.perf_counter()
        state.update(want=before + BURST, last=before, t_last=t0, done=Future())
        executor.spin_until_future_complete(state['done'], timeout_sec=120.0)
        seconds += state['t_last'] - t0
    return published, seconds


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
    runs = cfg.n_runs(full=3, quick=1)
    others = ('events',) if cfg.quick else ('events', 'multi')
    payloads = _payloads()
    workdir = Path(tempfile.mkdtemp(prefix='bench_recorder_'))
    results = []
    try:
        for r in cfg.progress(range(runs), desc='recorder', unit='run'):
            res = {'ceiling': run_stream('ceiling', 'single', payloads, rounds, workdir),
                   'recorder': run_stream('recorder', 'single', payloads, rounds, workdir / f'rec{r}')}
            for kind in others:
                res[f'ceiling_{kind}'] = run_stream('ceiling', kind, payloads, rounds, workdir)
            count = rounds * BURST
            res['writer'] = {'rate': count / run_writer(payloads, count, workdir / f'writer{r}')}
            results.append(res)
    finally:
        shutil.rmtree(workdir, ignore_errors=True)
    rate = {k: statistics.median(x[k]['rate'] for x in results) for k in results[0]}
    vs_ceiling = statistics.median(x['recorder']['rate'] / x['ceiling']['rate'] for x in results)
    vs_writer = statistics.median(x['recorder']['rate'] / x['writer']['rate'] for x in results)
    vs_events = statistics.median(x['recorder']['rate'] / x['ceiling_events']['rate'] for x in results)
    lost = max(x['recorder']['lost'] for x in results)
    rows = [['recorder node (SingleThreadedExecutor)', rate['recorder'], lost],
            ['ceiling: bare raw subscription (SingleThreadedExecutor)', rate['ceiling'],
             max(x['ceiling']['lost'] for x in results)]]
    rows += [[f'bare raw subscription ({"EventsExecutor" if k == "events" else "MultiThreadedExecutor"})',
              rate[f'ceiling_{k}'], max(x[f'ceiling_{k}']['lost'] for x in results)] for k in others]
    rows += [['rosbags Writer alone', rate['writer'], ''],
             ['recorder / ceiling', vs_ceiling, ''], ['recorder / Writer', vs_writer, ''],
             ['recorder / bare subscription on EventsExecutor', vs_events, '']]
    size = len(payloads[0])
    table = format_table(['path', 'msgs/s', 'lost'], rows)
    table += (f'\nnav_msgs/Odometry, {size} B CDR each; per run {rounds} bursts of {BURST} (reliable, keep-last 100 '
              f'publisher), {runs} run(s), medians; lost = published - received')
    data = {'message_bytes': size, 'burst': BURST, 'rounds': rounds, 'per_run': results,
            'recorder_msgs_per_s': rate['recorder'], 'rclpy_ceiling_msgs_per_s': rate['ceiling'],
            'writer_msgs_per_s': rate['writer'],
            **{f'rclpy_{k}_executor_msgs_per_s': rate[f'ceiling_{k}'] for k in others},
            'recorder_vs_rclpy_ceiling': vs_ceiling, 'recorder_vs_writer': vs_writer,
            'recorder_vs_events_executor_subscription': vs_events, 'recorder_lost': lost}
    return Outcome(table=table, data=data)

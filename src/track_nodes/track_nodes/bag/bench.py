"""``track-bench recorder``: messages per second through the real recorder node vs. rosbags alone.

One rclpy context on its own ROS_DOMAIN_ID with localhost-only discovery holds a publisher node
and a ``RecorderNode`` (spun by a SingleThreadedExecutor in a second thread). The publisher
sends pre-serialized ``nav_msgs/Odometry`` as fast as it can (reliable, keep-last 100) for a
fixed wall time; the recorder writes what it receives. Reported: messages published, recorded,
dropped, and the recorded rate (recorded messages / time until the recorder had drained).

Next to it, in the same run, the rosbags ``Writer`` alone writes the same serialized messages
to an MCAP bag: the ceiling of this path (no DDS, no executor). The ratio recorder / writer says
how much of the ceiling the node reaches. Timing lives here only, never in the tests.
"""

from __future__ import annotations

import os
import shutil
import tempfile
import threading
import time
from pathlib import Path

from track_core.cli import Outcome, RunConfig, format_table

TOPIC = '/bench/odom'
N_PAYLOADS = 1000
STALL = 0.5  # wall seconds without a new message = drained


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
    return 150 + os.getpid() % 80  # 150..229: away from the tests' 1..100


def run_recorder(payloads: list[bytes], seconds: float, workdir: Path) -> dict[str, float]:
    """Publish for ``seconds`` into a recorder node in the same context; count and time."""
    import rclpy
    from nav_msgs.msg import Odometry
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.parameter import Parameter
    from rclpy.qos import QoSProfile

    from track_nodes.bag.recorder import RecorderNode

    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    os.environ.pop('ROS_LOCALHOST_ONLY', None)
    context = Context()
    rclpy.init(context=context, domain_id=_domain_id())
    executor = SingleThreadedExecutor(context=context)
    pub_node = rclpy.create_node('bench_publisher', context=context)
    rec = None
    try:
        pub = pub_node.create_publisher(Odometry, TOPIC, QoSProfile(depth=100))
        rec = RecorderNode(context=context, parameter_overrides=[
            Parameter('bag', value=str(workdir / 'recorded')), Parameter('topics', value=[TOPIC])])
        executor.add_node(rec)
        spinner = threading.Thread(target=executor.spin, daemon=True)
        spinner.start()
        deadline = time.monotonic() + 15.0
        while pub.get_subscription_count() == 0:
            if time.monotonic() > deadline:
                raise OSError('recorder did not subscribe within 15 s (DDS discovery failed?)')
            time.sleep(0.01)
        time.sleep(0.2)

        published, t_pub, t0 = _publish_for(pub, payloads, seconds)
        recorded, t_rec = _wait_drained(rec, published, t0)
        executor.shutdown(timeout_sec=2.0)
        spinner.join(timeout=2.0)
    finally:
        if rec is not None:
            rec.destroy_node()
        pub_node.destroy_node()
        context.try_shutdown()
    return {'published': published, 'recorded': recorded, 'dropped': published - recorded,
            'publish_rate': published / t_pub, 'record_rate': recorded / t_rec, 'seconds': t_rec}


def _publish_for(pub, payloads: list[bytes], seconds: float) -> tuple[int, float, float]:
    """Publish as fast as possible for ``seconds``; → (count, seconds taken, start time)."""
    published, n = 0, len(payloads)
    t0 = time.perf_counter()
    stop = t0 + seconds
    while True:
        for _ in range(100):
            pub.publish(payloads[published % n])
            published += 1
        if time.perf_counter() >= stop:
            break
    return published, time.perf_counter() - t0, t0


def _wait_drained(rec, published: int, t0: float) -> tuple[int, float]:
    """Wait until the count equals ``published`` or has not moved for STALL s; → (count, s since t0)."""
    last, t_last = -1, time.perf_counter()
    while True:
        count = rec.message_counts().get(TOPIC, 0)
        now = time.perf_counter()
        if count != last:
            last, t_last = count, now
        if count >= published or now - t_last > STALL:
            return last, t_last - t0
        time.sleep(0.002)


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
    seconds = 1.5 if cfg.quick else 5.0
    runs = cfg.n_runs(full=3, quick=1)
    payloads = _payloads()
    workdir = Path(tempfile.mkdtemp(prefix='bench_recorder_'))
    try:
        results = []
        for r in cfg.progress(range(runs), desc='recorder', unit='run'):
            rec = run_recorder(payloads, seconds, workdir / f'run{r}')
            count = max(rec['recorded'], 10_000)
            writer_s = run_writer(payloads, count, workdir / f'writer{r}')
            rec['writer_rate'] = count / writer_s
            results.append(rec)
    finally:
        shutil.rmtree(workdir, ignore_errors=True)
    best = max(results, key=lambda x: x['record_rate'])
    writer_rate = max(x['writer_rate'] for x in results)
    ratio = best['record_rate'] / writer_rate
    size = len(payloads[0])
    table = format_table(
        ['path', 'msgs/s', 'published', 'recorded', 'dropped'],
        [['publisher (same process)', best['publish_rate'], best['published'], '', ''],
         ['recorder node (rclpy, raw sub)', best['record_rate'], best['published'], best['recorded'],
          best['dropped']],
         ['rosbags Writer alone (ceiling)', writer_rate, '', '', ''],
         ['ratio recorder / writer', ratio, '', '', '']])
    table += (f'\nnav_msgs/Odometry, {size} B CDR each, {seconds:g} s of publishing per run, best of {runs} '
              'run(s); drops = published - recorded (reliable keep-last 100 on both sides)')
    data = {'message_bytes': size, 'seconds': seconds, 'runs': results,
            'recorder_msgs_per_s': best['record_rate'], 'writer_msgs_per_s': writer_rate, 'ratio': ratio,
            'published': best['published'], 'recorded': best['recorded'], 'dropped': best['dropped']}
    return Outcome(table=table, data=data)

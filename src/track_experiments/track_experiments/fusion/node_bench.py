"""``track-bench fusion-node``: the real fusion node holding N tracks at 1 Hz, and the CPU share it takes.

The node (``FusionNode``: two sources, ``method exact``, ``rate`` 1 Hz, ``stale_after`` 2.5 s,
``window`` 10, ``publish_pairs`` as given, default ``nonzero``, ``display_rate`` 1 Hz) runs in
this process, spun by a SingleThreadedExecutor, on its own ROS_DOMAIN_ID with localhost-only
discovery. A publisher in a **child process** (so that its work is not counted) sends every
second the reports of every track: the Solent layout of
``track_experiments.fusion.bench.solent_layout`` (real ship positions, radar and patrol 2σ
ellipses; half the tracks on ``/bench/radar/reports``, half on ``/bench/patrol/reports``), each
report drawn around its track's position with the report's own covariance. ``input``:
``arrays`` (default) sends one ``track_msgs/TrackArray`` per source per second
(``track_array_topics``), ``poses`` one ``PoseWithCovarianceStamped`` per track with the local id
in ``header.frame_id`` (``pose_track_topics``). After a warm-up, for ``seconds`` of wall time:
this process's CPU time (user + system, every thread: executor, DDS, numpy) over the wall time is
the **CPU share** (1.0 = one core); per tick, the live tracks, the candidate pairs (scored), those
scoring > 0 and the tick's time. A
run in which a tick saw fewer live tracks than were published (the node fell behind) is flagged
``held_every_track: false`` and NOT HELD under the table.

Options (``--set``): ``tracks`` (1000; ``--quick``: 200), ``seconds`` (20; ``--quick``: 4),
``publish_pairs`` (``nonzero`` or ``all``), ``input`` (``arrays`` or ``poses``), ``stale_after``
(2.5 s: the reports come once a second at a phase unrelated to the node's ticks, and a burst of
1000 waits behind a running tick, so a report must outlive one period plus that lag; with 1.5 s a
track often drops out for a tick).
Needs the Solent data.
"""

from __future__ import annotations

import multiprocessing
import os
import resource
import time

import numpy as np

from track_experiments.cli import Outcome, RunConfig, format_table, set_keys

TOPICS = ('/bench/radar/reports', '/bench/patrol/reports')
WARMUP = 3.0


def _domain_id() -> int:
    return 150 + (os.getpid() + 37) % 80  # 150..229: away from the tests' 1..100 (and the recorder bench's)


def _cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def _publisher(domain: int, mu: np.ndarray, R: np.ndarray, seconds: float, seed: int, arrays: bool) -> None:
    """Child process: every second, the reports of every track (half on each topic), for ``seconds``."""
    import rclpy
    from geometry_msgs.msg import PoseWithCovarianceStamped
    from rclpy.context import Context
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

    from track_msgs.msg import TrackArray
    from track_msgs_py.odometry import position_to_pose_cov
    from track_msgs_py.topics import FRAME_MAP, track_frame_id
    from track_msgs_py.track_arrays import position_tracks, tracks_to_array

    context = Context()
    rclpy.init(context=context, domain_id=domain)
    node = rclpy.create_node('bench_tracks', context=context)
    qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10 if arrays else len(mu),
                     reliability=ReliabilityPolicy.RELIABLE)
    pubs = [node.create_publisher(TrackArray if arrays else PoseWithCovarianceStamped, t, qos) for t in TOPICS]
    rng = np.random.default_rng(seed)
    L = np.linalg.cholesky(R)
    half = len(mu) // 2
    ids = [f'{"rp"[k >= half]}{k:05d}' for k in range(len(mu))]
    t_end = time.monotonic() + seconds
    next_t = time.monotonic()
    while time.monotonic() < t_end:
        now = node.get_clock().now().nanoseconds * 1e-9
        z = mu + np.einsum('nij,nj->ni', L, rng.standard_normal((len(mu), 2)))
        if arrays:
            for pub, part in zip(pubs, (slice(0, half), slice(half, None)), strict=True):
                x, P = position_tracks(z[part], R[part])
                pub.publish(tracks_to_array(now, ids[part], [pub.topic_name] * len(x), x, P))
        else:
            for k in range(len(mu)):
                pubs[k >= half].publish(position_to_pose_cov(now, z[k], R[k], track_frame_id(FRAME_MAP, ids[k])))
        next_t += 1.0
        time.sleep(max(0.0, next_t - time.monotonic()))
    node.destroy_node()
    context.try_shutdown()


class _Probe:
    """Wraps a FusionNode: times each tick (FusionNode.tick's body) and counts the accepted reports."""

    def __init__(self, node) -> None:
        self.node, self.ticks, self.received = node, [], 0
        self._score, self._push = node.core.score, node._push
        node.timer.callback = self.tick
        node._push = self.push

    def push(self, *args) -> None:
        self.received += 1
        self._push(*args)

    def tick(self) -> None:
        t0 = time.perf_counter()
        instant = self._score(self.node._now())
        if instant is not None:
            self.node._publish(instant)
        pairs = instant.pairs if instant is not None else ()
        scored = int(np.sum(pairs.score > 0)) if len(pairs) else 0
        self.ticks.append((time.monotonic(), len(instant.ids) if instant is not None else 0, len(pairs), scored,
                           time.perf_counter() - t0))


def _spin(executor, until: float, done=lambda: False) -> None:
    while time.monotonic() < until and not done():
        executor.spin_once(timeout_sec=0.05)


def _figures(probe: _Probe, wall0: float, wall: float, n_tracks: int) -> dict:
    measured = [t for t in probe.ticks if wall0 <= t[0] <= wall0 + wall]
    if not measured:
        raise OSError('the fusion node scored no tick while measured (DDS discovery failed?)')
    arr = np.array([t[1:] for t in measured], float)
    held = int(np.count_nonzero(arr[:, 0] == n_tracks))
    return {'ticks': len(measured), 'ticks_holding_every_track': held, 'held_every_track': held == len(measured),
            'live_tracks_min': int(arr[:, 0].min()), 'live_tracks_max': int(arr[:, 0].max()),
            'pairs_per_tick': int(arr[:, 1].max()), 'nonzero_pairs_per_tick': float(arr[:, 2].mean()),
            'tick_s_mean': float(arr[:, 3].mean()), 'tick_s_max': float(arr[:, 3].max()),
            'tick_s_total': float(arr[:, 3].sum()),
            'per_tick': [{'live_tracks': int(a), 'pairs': int(b), 'nonzero': int(c), 'tick_s': float(d)}
                         for a, b, c, d in arr]}


def run_node(mu: np.ndarray, R: np.ndarray, seconds: float, publish_pairs: str, seed: int = 0,
             stale_after: float = 2.5, arrays: bool = True) -> dict:
    """Run the fusion node fed with the tracks (μ, R) at 1 Hz; → CPU share and per-tick figures."""
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.parameter import Parameter

    from track_nodes.fusion.fusion import FusionNode

    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    os.environ.pop('ROS_LOCALHOST_ONLY', None)
    domain = _domain_id()
    context = Context()
    rclpy.init(context=context, domain_id=domain)
    executor = SingleThreadedExecutor(context=context)
    node = FusionNode(node_name='fusion_bench', context=context, parameter_overrides=[
        Parameter('track_array_topics' if arrays else 'pose_track_topics', value=list(TOPICS)),
        Parameter('rate', value=1.0), Parameter('display_rate', value=1.0),
        Parameter('stale_after', value=float(stale_after)), Parameter('method', value='exact'),
        Parameter('window', value=10),
        Parameter('publish_pairs', value=publish_pairs)])
    probe = _Probe(node)
    executor.add_node(node)
    child = multiprocessing.get_context('spawn').Process(
        target=_publisher, args=(domain, mu, R, seconds + WARMUP + 32.0, seed, arrays), daemon=True)
    try:
        child.start()
        # warm-up: every track reported once, then WARMUP seconds more
        _spin(executor, time.monotonic() + 30.0, lambda: len(node.core.table.latest) >= len(mu))
        _spin(executor, time.monotonic() + WARMUP)
        received0, cpu0, wall0 = probe.received, _cpu(), time.monotonic()
        _spin(executor, wall0 + seconds)
        cpu, wall, received = _cpu() - cpu0, time.monotonic() - wall0, probe.received - received0
    finally:
        child.terminate()
        child.join(timeout=10.0)
        executor.shutdown(timeout_sec=2.0)
        node.destroy_node()
        context.try_shutdown()
    return {'tracks': len(mu), 'publish_pairs': publish_pairs, 'input': 'arrays' if arrays else 'poses',
            'stale_after': float(stale_after), 'seconds': wall,
            'cpu_s': cpu, 'cpu_share': cpu / wall,
            'reports_received_per_s': received / wall, **_figures(probe, wall0, wall, len(mu))}


@set_keys(tracks='tracks held (1000; --quick: 200)', seconds='wall seconds measured (20; --quick: 4)',
          publish_pairs='nonzero or all (nonzero)', stale_after='seconds a report lives in the node (2.5)',
          input='arrays (one TrackArray per source per second) or poses (one message per track) (arrays)')
def bench(cfg: RunConfig) -> Outcome:
    from track_experiments.fusion.bench import solent_layout

    n = int(cfg.options.get('tracks', 200 if cfg.quick else 1000))
    seconds = float(cfg.options.get('seconds', 4.0 if cfg.quick else 20.0))
    publish_pairs = cfg.choice('publish_pairs', 'nonzero', 'all')
    kind = cfg.choice('input', 'arrays', 'poses')
    rng = np.random.default_rng(cfg.seed)
    mu, R = solent_layout(n, rng)
    r = run_node(mu, R, seconds, publish_pairs, cfg.seed, float(cfg.options.get('stale_after', 2.5)), kind == 'arrays')
    table = format_table(['tracks', 'input', 'publish', 'wall s', 'CPU s', 'CPU share', 'reports/s', 'ticks',
                          'live tracks', 'candidates', 'score > 0', 'tick s mean', 'tick s max', 'in ticks s'],
                         [[r['tracks'], kind, publish_pairs, r['seconds'], r['cpu_s'], r['cpu_share'],
                           r['reports_received_per_s'], r['ticks'], f'{r["live_tracks_min"]}–{r["live_tracks_max"]}',
                           r['pairs_per_tick'], r['nonzero_pairs_per_tick'], r['tick_s_mean'], r['tick_s_max'],
                           r['tick_s_total']]])
    table += ('\nfusion node in this process (exact score, gated; 1 Hz); publisher in a child process, not counted; '
              'CPU share = process CPU time / wall time (1.0 = one core)')
    if not r['held_every_track']:  # the node fell behind: its CPU share is not that of holding n tracks
        table += (f'\nNOT HELD: only {r["ticks_holding_every_track"]} of {r["ticks"]} ticks had all {n} tracks live '
                  f'({r["live_tracks_min"]}-{r["live_tracks_max"]}); the figures above are not those of {n} tracks')
    return Outcome(table, r)

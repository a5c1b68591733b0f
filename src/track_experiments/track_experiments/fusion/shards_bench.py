"""``track-bench fusion-shards``: 10,000 tracks at 1 Hz fused by region shards, each a fusion node in its own process.

A publisher process steps a ``SyntheticSea`` (constant ship density, moving ships) once a second
and sends each source's tracks as one ``track_msgs/TrackArray`` (stamps k seconds after a fixed
epoch). ``shards`` = nx × ny fusion nodes (``region.grid`` over the sea, ``region_margin`` from
``region.margin_needed`` with the sea's largest 2σ axis and speed) run as separate processes, on
their own ROS_DOMAIN_ID with localhost-only discovery, with ``schedule stamps`` (the instants are
the data's, so every node scores the same instants), ``publish_pairs nonzero``, window 10, exact
score. Each process subscribes to its own node's ``fusion/scores`` and
returns the pairs it published and its CPU time (user + system, every thread) over the wall time of
the measured ticks: the **CPU share** (1.0 = one core).

The single node to compare with is the fusion node's core (``PairAssociator`` with the node's
defaults and the same settings) fed, in this process after the run, the same tracks in the order
the node takes them (``reference``): what one unsharded node publishes when it keeps up with the
data. (Run live beside the shards on two cores, a 10,000-track node falls more than a period behind
and takes the next tick's radar array before the current tick's patrol array, which the stamp
schedule's rule does not cover; see the fusion node's docstring.) ``max_abs_diff``: over the
instants every shard scored, the largest difference of any pair's score, combination or window
length between the shards (each pair from the shard that owns it) and the single node;
``missing``/``extra``: pairs only the single node, or only a shard, published; ``verdicts_differ``:
pairs associated by one side only. All must be 0.

Options (``--set``): ``tracks`` (10,000; ``--quick``: 1000), ``ticks`` (20; ``--quick``: 8),
``shards`` (``2x2``).
"""

from __future__ import annotations

import multiprocessing
import os
import resource
import time

import numpy as np

from track_core.ais import PATROL
from track_core.fusion.region import grid, margin_needed
from track_experiments.cli import Outcome, RunConfig, format_table, set_keys
from track_experiments.fusion.sea import SyntheticSea

TOPICS = ('/bench/radar/tracks', '/bench/patrol/tracks')
EPOCH = 1.7e9
WINDOW, STALE = 10, 2.5
# The nodes' association parameters (the rest: the node's defaults); the reference's core has the same config.
FUSION = {'schedule': 'stamps', 'rate': 1.0, 'window': WINDOW, 'stale_after': STALE}


def _domain_id() -> int:
    return 150 + (os.getpid() + 53) % 80


def _cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def _publisher(domain: int, n: int, seed: int, ticks: int, nodes: int, ready, done) -> None:
    """Child: the sea's two sources, one TrackArray each per second once every node's subscription matched."""
    import rclpy
    from rclpy.context import Context
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

    from track_msgs.msg import TrackArray
    from track_msgs_py.track_arrays import position_tracks, tracks_to_array

    context = Context()
    rclpy.init(context=context, domain_id=domain)
    node = rclpy.create_node('bench_sea', context=context)
    qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=ticks, reliability=ReliabilityPolicy.RELIABLE)
    pubs = [node.create_publisher(TrackArray, t, qos) for t in TOPICS]   # keeps the run: a slow node loses nothing
    sea = SyntheticSea(n, np.random.default_rng(seed))
    half = sea.ships
    ready.wait()
    deadline = time.monotonic() + 120.0
    while min(p.get_subscription_count() for p in pubs) < nodes and time.monotonic() < deadline:
        time.sleep(0.1)
    start = time.time() + 1.0
    for k in range(ticks):
        time.sleep(max(0.0, start + k - time.time()))
        mu, R = sea.step(1.0)
        for pub, part in zip(pubs, (slice(0, half), slice(half, None)), strict=True):
            x, P = position_tracks(mu[part], R[part])
            pub.publish(tracks_to_array(EPOCH + k, sea.ids[part], [pub.topic_name] * len(x), x, P))
    done.wait(ticks + 240.0)        # until every node has its results (reliable delivery needs the writer)
    node.destroy_node()
    context.try_shutdown()


def _fusion(domain: int, name: str, region: list[float], margin: float, ticks: int, out, ready) -> None:
    """Child: one fusion node (and a sink of its scores); → its pairs, live tracks and CPU share."""
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.parameter import Parameter

    from track_msgs.msg import PairScoreArray
    from track_msgs_py.qos import ESTIMATE_QOS
    from track_msgs_py.records.fusion import FusionPairs
    from track_nodes.fusion.fusion import FusionNode

    context = Context()
    rclpy.init(context=context, domain_id=domain)
    node = FusionNode(node_name='fusion', namespace=name, context=context, parameter_overrides=[
        Parameter('track_array_topics', value=list(TOPICS)), *(Parameter(k, value=v) for k, v in FUSION.items()),
        Parameter('publish_pairs', value='nonzero'), Parameter('region', value=region),
        Parameter('region_margin', value=float(margin)), Parameter('stamp_horizon', value=1e9),
        Parameter('stamp_lead', value=1e9)])
    pairs: dict = {}
    live: list[int] = []
    publish = node._publish

    def probe(instant) -> None:
        live.append(len(instant.ids))
        publish(instant)

    node._publish = probe
    arrays = {'n': 0}
    on_array = node._on_track_array

    def counting(topic, msg) -> None:
        arrays['n'] += 1
        on_array(topic, msg)

    node._on_track_array = counting

    def on_scores(msg) -> None:
        rec = FusionPairs.from_msg(msg)
        for (a, b), s, c, n, v in rec.rows():
            pairs[(round(rec.t - EPOCH, 3), *sorted((a, b)))] = (s, c, n, v)

    node.create_subscription(PairScoreArray, 'fusion/scores', on_scores, ESTIMATE_QOS)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    deadline = time.monotonic() + 120.0   # matched both sources before the first array: none is missed
    while min(len(node.get_publishers_info_by_topic(t)) for t in TOPICS) < 1 and time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.1)
    ready.set()
    cpu0 = wall0 = None
    deadline = time.monotonic() + ticks + 120.0
    while len(live) < ticks - 1 and time.monotonic() < deadline:   # the last instant is scored by a later report
        executor.spin_once(timeout_sec=0.1)
        if cpu0 is None and live:
            cpu0, wall0 = _cpu(), time.monotonic()
    for _ in range(20):                                            # the last scores through the sink
        executor.spin_once(timeout_sec=0.05)
    cpu, wall = (_cpu() - cpu0, time.monotonic() - wall0) if cpu0 is not None else (0.0, 1.0)
    out.put((name, {'pairs': pairs, 'live': live, 'cpu_s': cpu, 'wall_s': wall, 'outside': node.shard.outside,
                    'arrays': arrays['n']}))
    executor.shutdown(timeout_sec=2.0)
    node.destroy_node()
    context.try_shutdown()


def compare(single: dict, shards: list[dict]) -> dict:
    """max |difference| and the pairs one side lacks, over the instants every node scored."""
    instants = set.intersection(*({k[0] for k in r['pairs']} for r in (single, *shards)))
    want = {k: v for k, v in single['pairs'].items() if k[0] in instants}
    got: dict = {}
    for r in shards:
        got |= {k: v for k, v in r['pairs'].items() if k[0] in instants}
    both = want.keys() & got.keys()
    diff = max((abs(float(a) - float(b)) for k in both for a, b in zip(want[k][:3], got[k][:3], strict=True)),
               default=0.0)
    return {'instants_compared': len(instants), 'pairs_compared': len(both), 'max_abs_diff': diff,
            'missing': len(want.keys() - got.keys()), 'extra': len(got.keys() - want.keys()),
            'verdicts_differ': sum(want[k][3] != got[k][3] for k in both),
            'associated': sum(bool(v[3]) for v in want.values())}


def run(n: int, ticks: int, nx: int, ny: int, seed: int) -> dict:
    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    os.environ.pop('ROS_LOCALHOST_ONLY', None)
    sea = SyntheticSea(n, np.random.default_rng(seed))
    r_max = 2.0 * PATROL.sigma_major                         # the largest 2σ semi-axis of the sea's tracks
    v_max = float(np.max(np.linalg.norm(sea.vel, axis=1)))
    margin = 1.25 * margin_needed(r_max, v_max, WINDOW, 1.0, STALE)
    regions = grid(0.0, sea.side, 0.0, sea.side, nx, ny, margin)
    names = [f'shard{k}' for k in range(len(regions))]
    bounds = [[r.xmin, r.xmax, r.ymin, r.ymax] for r in regions]
    ctx = multiprocessing.get_context('spawn')
    domain, out = _domain_id(), ctx.Queue()
    ready = [ctx.Event() for _ in names]
    procs = [ctx.Process(target=_fusion, args=(domain, nm, b, margin, ticks, out, ev),
                         daemon=True) for nm, b, ev in zip(names, bounds, ready, strict=True)]
    go, done = ctx.Event(), ctx.Event()
    pub = ctx.Process(target=_publisher, args=(domain, n, seed, ticks, len(names), go, done), daemon=True)
    pub.start()
    for p in procs:
        p.start()
    for ev in ready:
        ev.wait(180.0)
    go.set()
    results = {}
    try:
        for _ in names:
            name, r = out.get(timeout=ticks + 240.0)
            results[name] = r
    finally:
        done.set()
        for p in (*procs, pub):
            p.join(timeout=10.0)
            if p.is_alive():
                p.terminate()
    shards = [results[nm] for nm in names]
    single = reference(n, ticks, seed)
    row = {'tracks': n, 'shards': len(regions), 'grid': f'{nx}x{ny}', 'margin_m': margin, 'sea_km': sea.side / 1000,
           'ticks': ticks, **compare(single, shards),
           'single': {'core_tick_s': single['core_tick_s'], 'live_tracks': _mean(single['live'])},
           'per_shard': [{'cpu_share': r['cpu_s'] / r['wall_s'], 'live_tracks': _mean(r['live']),
                          'instants': len(r['live']), 'reports_outside': r['outside'], 'arrays': r['arrays']}
                         for r in shards]}
    row['arrays_lost'] = sum(2 * ticks - r['arrays'] for r in shards)
    return row


def reference(n: int, ticks: int, seed: int) -> dict:
    """The unsharded node's pairs: its core with its defaults, fed the run's tracks in the node's order."""
    from track_core.fusion import PairAssociator, TrackReport
    from track_nodes.fusion.params import associator_config

    core = PairAssociator(associator_config(FUSION))
    sea = SyntheticSea(n, np.random.default_rng(seed))
    half = sea.ships
    pairs, live, cpu = {}, [], []
    for k in range(ticks):
        mu, R = sea.step(1.0)
        for topic, part in zip(TOPICS, (range(0, half), range(half, n)), strict=True):   # radar, then patrol
            for i in part:
                c0 = time.process_time()
                instants = core.push(topic, f'{topic}/{sea.ids[i]}', TrackReport(EPOCH + k, mu[i], R[i]))
                cpu.append(time.process_time() - c0) if instants else None
                for inst in instants:
                    live.append(len(inst.ids))
                    q = inst.pairs.subset((inst.pairs.score > 0) | (inst.pairs.combined > 0) | inst.pairs.associated)
                    for a, b, s, c, m, v in zip(q.ia.tolist(), q.ib.tolist(), q.score.tolist(), q.combined.tolist(),
                                                q.instants.tolist(), q.associated.tolist(), strict=True):
                        pairs[(round(inst.t - EPOCH, 3), *sorted((inst.ids[a], inst.ids[b])))] = (s, c, m, v)
    return {'pairs': pairs, 'live': live, 'core_tick_s': float(np.median(cpu)) if cpu else 0.0}


def _mean(v) -> float:
    return float(np.mean(v)) if len(v) else 0.0


@set_keys(tracks='tracks (10000; --quick: 1000)', ticks='1 s ticks published (20; --quick: 8)',
          shards='grid of shards, NXxNY (2x2)')
def bench(cfg: RunConfig) -> Outcome:
    n = int(cfg.options.get('tracks', 1000 if cfg.quick else 10_000))
    ticks = int(cfg.options.get('ticks', 8 if cfg.quick else 20))
    nx, ny = (int(v) for v in str(cfg.options.get('shards', '2x2')).lower().split('x'))
    r = run(n, ticks, nx, ny, cfg.seed)
    rows = [[f'shard {k}', f'{s["live_tracks"]:.0f}', s['cpu_share'], s['instants'], s['arrays'], s['reports_outside']]
             for k, s in enumerate(r['per_shard'])]
    table = format_table(['node', 'tracks held', 'CPU share', 'instants', 'arrays in', 'reports outside'], rows)
    table += (f'\nsingle node (its core in-process, the same tracks): {r["single"]["live_tracks"]:.0f} tracks, '
              f'{r["single"]["core_tick_s"]:.3f} CPU s per scored instant')
    table += (f'\n{r["tracks"]} tracks at 1 Hz, {r["shards"]} shards ({r["grid"]}, margin {r["margin_m"]:.0f} m, sea '
              f'{r["sea_km"]:.1f} km square), each node a process; over {r["instants_compared"]} instants and '
              f'{r["pairs_compared"]} pairs: max |shards - single| = {r["max_abs_diff"]:g}, missing {r["missing"]}, '
              f'extra {r["extra"]}, verdicts differ {r["verdicts_differ"]} ({r["associated"]} associated)')
    return Outcome(table, r)

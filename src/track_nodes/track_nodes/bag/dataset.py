"""``track-dataset``: convert real data sets into rosbag2 bags the ``player`` can replay.

Usage::

    track-dataset victoria-park --out DIR [--data DIR] [--t-max SECONDS] [--epoch E] [--standard]

``victoria-park`` reads ``inputs.dat``, ``measurements.dat`` and ``gps.dat`` of the ACFR Victoria
Park run (default: ``track_core.slam.victoria.data_dir()``) and writes a rosbag2 bag (version 9,
MCAP, CDR) to the new directory ``DIR`` (never overwritten) with ``/slam/inputs`` (TwistStamped:
``linear.x`` encoder speed, ``angular.z`` steering angle), ``/slam/scan`` (PointCloud2 per scan:
``x``, ``y``, ``z`` in the laser frame, ``range`` to the trunk surface, ``bearing`` as eq. 5,
``diameter``), ``/slam/gps`` (PointStamped in ``gps``, jumps included) and ``/tf_static`` map → gps
(transient-local; the first fix at the map origin, rotation 0).

Dates: data time t is stamped ``epoch + t`` in integer nanoseconds (``--epoch``: seconds since 1970
or an ISO date in UTC; default: the run ends at the conversion's whole second); ``custom_data``
``data_time_origin_ns`` keeps the origin. Messages in time order (a scan before an input at equal
t). ``--standard`` writes ``/odom``, odom → base_link on ``/tf`` and ``/slam/landmarks`` instead
(``victoria_standard_messages``), for ``slam`` with ``input_model: odometry``, ``observations:
detections``, ``laser_pose: [3.78, 0.5, 0]``. ``--t-max S`` keeps t ≤ S. Bad paths, files or
options: one line on stderr, exit 2. Do not commit converted bags: they are derived data.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from track_nodes.bag.api import one_line
from track_nodes.base.cli import OneLineParser
from track_nodes.base.epoch import EpochError, parse_epoch

EXIT_BAD_INPUT = 2
DATA_TIME_ORIGIN = 'data_time_origin_ns'  # metadata.yaml custom_data: data time = stamp - origin [ns]


class DatasetError(ValueError):
    """The conversion cannot be done; the message is one line."""


def load_victoria(data: Path | None, t_max: float | None):
    """``victoria.load`` with raw ranges (add_radius=False), every problem as one-line ``DatasetError``."""
    from track_core.slam import victoria

    path = Path(data) if data is not None else victoria.data_dir()
    if not path.is_dir():
        raise DatasetError(f'{path}: Victoria Park data folder not found (expected inputs.dat, measurements.dat, '
                           'gps.dat; give --data DIR or set TRACK_VICTORIA_PARK)')
    missing = [f for f in ('inputs.dat', 'measurements.dat', 'gps.dat') if not (path / f).is_file()]
    if missing:
        raise DatasetError(f'{path}: not a Victoria Park data folder: missing {", ".join(missing)}')
    try:
        vp = victoria.load(path, t_max=t_max, add_radius=False)
    except (OSError, ValueError, IndexError) as exc:
        raise DatasetError(f'{path}: cannot read the data: {one_line(exc)}') from None
    if vp.inputs.ndim != 2 or vp.inputs.shape[1] < 3 or len(vp.scans) == 0:
        raise DatasetError(f'{path}: no usable rows' + (f' with t <= {t_max:g} s' if t_max is not None else ''))
    return vp


def data_time_origin(bag: Path | str) -> int:
    """The ``data_time_origin_ns`` of a converted bag (0 when absent: its stamps are the data's own time)."""
    import yaml

    meta = yaml.safe_load((Path(bag) / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    return int((meta.get('custom_data') or {}).get(DATA_TIME_ORIGIN, 0))


def _shifted(msg, t: float, epoch_ns: int):
    """``msg`` restamped at ``epoch + t`` in integer nanoseconds (its builder took the float data time)."""
    from track_msgs_py.stamps import ns_to_stamp

    header = msg.header if hasattr(msg, 'header') else msg.transforms[0].header
    header.stamp = ns_to_stamp(epoch_ns + round(t * 1e9))
    return msg


def victoria_messages(vp, epoch_ns: int = 0):
    """(t, topic, message) of the whole run in time order (scan before input at equal t, then GPS),
    after the map → gps static transform (when there is GPS); stamped at ``epoch_ns`` + t."""
    import numpy as np
    from geometry_msgs.msg import PointStamped
    from std_msgs.msg import Header

    from track_msgs_py.clouds import scan_to_pointcloud2
    from track_msgs_py.odometry import inputs_to_twist
    from track_msgs_py.stamps import sec_to_stamp
    from track_msgs_py.tf import planar_transform, tf_message
    from track_msgs_py.topics import FRAME_GPS, FRAME_MAP, SLAM_GPS, SLAM_INPUTS, SLAM_SCAN, TF_STATIC

    t_in, t_sc, t_gps = vp.inputs[:, 0], np.asarray(vp.scan_t, dtype=float), vp.gps[:, 0]
    times = np.concatenate([t_sc, t_in, t_gps])
    if vp.gps.shape[0]:
        t0 = float(times.min())
        gps0 = -vp.gps[0, 1:]  # the gps frame's origin in map: the first fix at the map origin, rotation 0
        yield t0, TF_STATIC, _shifted(tf_message([planar_transform(t0, FRAME_MAP, FRAME_GPS, gps0[0], gps0[1], 0.0)]),
                                      t0, epoch_ns)
    prio = np.concatenate([np.zeros(t_sc.size), np.ones(t_in.size), np.full(t_gps.size, 2)])
    order = np.lexsort((prio, times))  # by time, then scan < input < gps
    k_sc, k_in = t_sc.size, t_sc.size + t_in.size
    for j in order.tolist():
        if j < k_sc:
            yield float(t_sc[j]), SLAM_SCAN, _shifted(scan_to_pointcloud2(t_sc[j], vp.scans[j], vp.diameters[j]),
                                                      t_sc[j], epoch_ns)
        elif j < k_in:
            _, v, a = vp.inputs[j - k_sc]
            yield float(t_in[j - k_sc]), SLAM_INPUTS, _shifted(inputs_to_twist(t_in[j - k_sc], v, a), t_in[j - k_sc],
                                                               epoch_ns)
        else:
            t, x, y = vp.gps[j - k_in]
            msg = PointStamped(header=Header(stamp=sec_to_stamp(t), frame_id=FRAME_GPS))
            msg.point.x, msg.point.y = float(x), float(y)
            yield float(t), SLAM_GPS, _shifted(msg, t, epoch_ns)


def victoria_standard_messages(vp, epoch_ns: int = 0):
    """(t, topic, message) of the run as a robot with standard drivers gives it (``--standard``), in time order
    (odometry before detections at equal t: the detections are placed through odom -> base_link), with the
    GPS and map -> gps of ``victoria_messages``: ``/odom`` (nav_msgs/Odometry of base_link in odom, twist
    with covariance, ``victoria.standard_stream``), ``/tf`` (odom -> base_link, the same pose) and
    ``/slam/landmarks`` (track_msgs/LandmarkDetectionArray in ``laser``: range to the centre, REP-103 bearing)."""
    import numpy as np

    from track_core.slam import victoria
    from track_core.slam.profiles import VICTORIA_PARK
    from track_msgs_py.records.landmarks import LandmarkDetections, planar_odometry_msg
    from track_msgs_py.tf import planar_transform, tf_message
    from track_msgs_py.topics import (
        FRAME_BASE,
        FRAME_LASER,
        FRAME_ODOM,
        SLAM_INPUTS,
        SLAM_LANDMARKS,
        SLAM_ODOM,
        SLAM_SCAN,
        TF,
    )

    sr = victoria.standard_stream(vp, add_radius=True)
    rest = [m for m in victoria_messages(vp, epoch_ns) if m[1] not in (SLAM_SCAN, SLAM_INPUTS)]  # GPS, map -> gps
    R = np.diag([VICTORIA_PARK.slam.sigma_r ** 2, VICTORIA_PARK.slam.sigma_b ** 2, 0.0])  # the data give none
    items = ([(t, 0, k) for k, t in enumerate(sr.odom_t.tolist())]
             + [(t, 1, k) for k, t in enumerate(sr.scan_t.tolist())])
    items.sort()
    out = []
    for t, kind, k in items:
        if kind == 0:
            pose = sr.odom_pose[k]
            out.append((t, SLAM_ODOM, _shifted(planar_odometry_msg(t, pose, *sr.twist[k], sr.twist_cov[k], FRAME_ODOM,
                                                                   FRAME_BASE), t, epoch_ns)))
            out.append((t, TF, _shifted(tf_message([planar_transform(t, FRAME_ODOM, FRAME_BASE, *pose)]), t, epoch_ns)))
        else:
            d = sr.detections[k]
            rec = LandmarkDetections(t, FRAME_LASER, d[:, 0], d[:, 1], d[:, 2], np.broadcast_to(R, (len(d), 3, 3)),
                                     np.full(len(d), -1, np.int32))
            out.append((t, SLAM_LANDMARKS, _shifted(rec.to_msg(), t, epoch_ns)))
    yield from sorted(rest + out, key=lambda m: m[0])   # stable: map -> gps first, odometry before detections


def write_bag(out: Path, messages, topics: dict[str, str], custom: dict[str, str] | None = None) -> dict[str, int]:
    """Write (t, topic, msg) to a new rosbag2 v9 MCAP bag at ``out``, each at its header stamp (integer ns);
    ``custom`` goes into the metadata's ``custom_data``; → message count per topic."""
    from rclpy.serialization import serialize_message

    from track_msgs_py.qos import qos_for_topic
    from track_msgs_py.stamps import stamp_to_ns
    from track_nodes.bag.api import qos_to_rosbags
    from track_nodes.bag.typestore import typestore
    from track_nodes.bag.writer import BagWriter

    ts = typestore()   # the Jazzy types and track_msgs (the detections of --standard)
    counts = dict.fromkeys(topics, 0)
    writer = BagWriter(out).open()
    try:
        for key, value in (custom or {}).items():
            writer.set_custom_data(key, value)
        conns = {topic: writer.add_connection(topic, msgtype, typestore=ts,
                                              offered_qos_profiles=[qos_to_rosbags(qos_for_topic(topic))])
                 for topic, msgtype in topics.items()}
        for _, topic, msg in messages:
            header = msg.header if hasattr(msg, 'header') else msg.transforms[0].header  # a TFMessage has none
            writer.write(conns[topic], stamp_to_ns(header.stamp), serialize_message(msg))
            counts[topic] += 1
    except BaseException:
        writer.abort()
        raise
    writer.close()
    return counts


def convert_victoria_park(out: Path, data: Path | None = None, t_max: float | None = None,
                          epoch: int | None = None, standard: bool = False) -> dict[str, int]:
    """Convert; ``epoch`` [whole s since 1970] is the bag time of data time 0 (None: the run ends now);
    ``standard``: as odometry + landmark detections (``victoria_standard_messages``)."""
    import math
    import time

    from track_msgs_py.topics import SLAM_GPS, SLAM_INPUTS, SLAM_LANDMARKS, SLAM_ODOM, SLAM_SCAN, TF, TF_STATIC, TOPICS

    if t_max is not None and not t_max > 0:
        raise DatasetError(f'--t-max {t_max}: must be > 0')
    out = Path(out)
    if out.exists():
        raise DatasetError(f'{out}: exists already, not overwriting (choose another --out)')
    vp = load_victoria(data, t_max)
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise DatasetError(f'{out.parent}: cannot create the folder for --out: {one_line(exc)}') from None
    kept = (SLAM_ODOM, TF, SLAM_LANDMARKS, SLAM_GPS, TF_STATIC) if standard else (SLAM_INPUTS, SLAM_SCAN, SLAM_GPS,
                                                                                   TF_STATIC)
    topics = {t: TOPICS[t].msgtype for t in kept}
    if epoch is None:  # the run ends at the conversion's whole second: every stamp is in the past
        t_end = max(float(vp.inputs[:, 0].max()), float(max(vp.scan_t)), float(vp.gps[:, 0].max(initial=0.0)))
        epoch = time.time_ns() // 1_000_000_000 - math.ceil(t_end)
    epoch_ns = int(epoch) * 1_000_000_000
    messages = victoria_standard_messages(vp, epoch_ns) if standard else victoria_messages(vp, epoch_ns)
    return write_bag(out, messages, topics, {DATA_TIME_ORIGIN: str(epoch_ns), 'data_set': 'victoria_park'})


def _parser() -> argparse.ArgumentParser:
    ap = OneLineParser(prog='track-dataset', description='Convert a real data set into a rosbag2 MCAP bag.')
    sub = ap.add_subparsers(dest='dataset', required=True, metavar='DATASET', parser_class=OneLineParser)
    vp = sub.add_parser('victoria-park', help='the ACFR Victoria Park run (inputs, laser scans of trees, GPS)',
                        description='Write /slam/inputs, /slam/scan and /slam/gps, stamped with the data times '
                                    'shifted to --epoch, to a new rosbag2 MCAP bag.')
    vp.add_argument('--out', type=Path, required=True, metavar='DIR', help='new bag directory to write')
    vp.add_argument('--data', type=Path, default=None, metavar='DIR',
                    help='data folder (default: $TRACK_VICTORIA_PARK or victoria_park/ of the data folder)')
    vp.add_argument('--t-max', type=float, default=None, metavar='SECONDS', help='keep only data with t <= SECONDS')
    vp.add_argument('--standard', action='store_true',
                    help='write what a robot with standard drivers publishes: /odom (nav_msgs/Odometry), odom -> '
                         'base_link on /tf and /slam/landmarks (track_msgs/LandmarkDetectionArray), for slam with '
                         'input_model odometry and observations detections')
    vp.add_argument('--epoch', default='now', metavar='E',
                    help="bag time of the data's time 0: whole seconds since 1970 or an ISO date (UTC); 'now' "
                         '(default): the run ends at the conversion; the data time stays in the metadata '
                         '(data_time_origin_ns)')
    return ap


def main(argv: Sequence[str] | None = None) -> int:
    args = _parser().parse_args(list(sys.argv[1:] if argv is None else argv))
    try:
        try:
            epoch = parse_epoch(args.epoch)
        except EpochError as exc:
            raise DatasetError(str(exc)) from None
        counts = convert_victoria_park(args.out, args.data, args.t_max, epoch, args.standard)
    except DatasetError as exc:
        print(f'track-dataset: {exc}', file=sys.stderr)
        return EXIT_BAD_INPUT
    total = sum(counts.values())
    print(f'{args.out}: {total} messages (' + ', '.join(f'{t} {n}' for t, n in counts.items()) + ')', flush=True)
    return 0


if __name__ == '__main__':
    raise SystemExit(main())

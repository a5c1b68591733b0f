"""Broken scans must not wedge the slam node. A scan it refuses leaves the stream merger's stamps, buffer
and filter untouched: a scan with no usable observation, whatever its stamp, must neither advance the scan
stream nor reach the filter, or every valid scan after it is refused as "time went backwards". And a
flood of refused scans is no pause of the scan stream (``StreamMerger.heard``), or the inputs run past
the next valid scans and each of those is refused as late, for good."""

from __future__ import annotations

import copy
import time

import numpy as np
import pytest
from rclpy.parameter import Parameter

from track_experiments.fuzz.generate import Fuzzer
from track_msgs_py.clouds import scan_to_pointcloud2, table_to_pointcloud2
from track_msgs_py.odometry import inputs_to_twist
from track_nodes.slam.slam import SlamNode

pytestmark = pytest.mark.integration

TREES = np.array([[10.0, 1.0], [12.0, 2.0], [15.0, 1.5]])


def _slam(ros, **params):
    """A slam node fed by calling its callbacks (deterministic); poses captured instead of published."""
    over = [Parameter(k, value=v) for k, v in params.items()]
    slam = ros.add(SlamNode(context=ros.context, parameter_overrides=over))
    poses: list = []
    slam.pub_pose.publish = poses.append
    return slam, poses


def _scan(t: float, trees=TREES):
    return scan_to_pointcloud2(t, trees, np.full(len(trees), 0.3))


def _feed(slam, t: float) -> None:
    slam._on_scan(_scan(t))
    slam._on_input(inputs_to_twist(t + 0.05, 1.0, 0.0))


def _merger_state(slam):
    m = slam.merger
    return (dict(m.last_ns), dict(m._arrival), dict(m._count), m._seq, len(m), m.processed_ns, slam.slam.n_scans)


def _garbage_scans(t_next: float) -> list:
    """Scans stamped at ``t_next`` whose every observation is unusable: the fuzzer's NaN/inf data, and
    a scan whose ranges are all negative."""
    fuzzer = Fuzzer({'/slam/scan': _scan(t_next)}, seed=0)
    kinds = {'cloud.nan_data', 'cloud.inf_data'}
    out = [fn(copy.deepcopy(fuzzer.templates['/slam/scan']), 1) for _, kind, fn in fuzzer.plan if kind in kinds]
    assert len(out) == len(kinds)
    return [*out, _scan(t_next, np.array([[-1.0, 1.0], [-2.0, 1.5]]))]


def test_a_scan_without_a_usable_observation_is_refused_whole(ros):
    slam, poses = _slam(ros)
    slam._on_input(inputs_to_twist(1.0, 1.0, 0.0))
    _feed(slam, 1.05)
    assert len(poses) == 1
    for bad in _garbage_scans(1.3):
        before, refused = _merger_state(slam), slam.refusals.total()
        slam._on_scan(bad)
        assert _merger_state(slam) == before and slam.refusals.total() == refused + 1
    assert slam.n_bad_scans == 3 and len(poses) == 1
    _feed(slam, 1.2)  # the valid stream goes on at its own pace
    assert slam.n_scans == 2 and len(poses) == 2


def test_broken_scans_stamped_ahead_do_not_wedge_the_node(ros):
    """Garbage stamped 30 s ahead (inside the stamp horizon): the node stays at the valid stream's time."""
    slam, poses = _slam(ros)
    slam._on_input(inputs_to_twist(1.0, 1.0, 0.0))
    _feed(slam, 1.05)
    for k in range(50):
        for bad in _garbage_scans(31.0 + 0.01 * k):
            slam._on_scan(bad)
    for k in range(10):
        _feed(slam, 1.2 + 0.1 * k)
    assert slam.n_scans == 11 and len(poses) == 11, slam.refusals.by_key()


def test_a_flood_of_refused_scans_does_not_pause_the_scan_stream(ros):
    # pause_wall is wall time: a gap longer than it between two calls below is a real pause, so it is
    # long enough (0.5 s) that a busy machine's stall between an input and its scan is not one
    pause = 0.5
    slam, poses = _slam(ros, pause_wall=pause)
    slam._on_input(inputs_to_twist(1.0, 1.0, 0.0))
    for k in range(5):
        _feed(slam, 1.05 + 0.1 * k)
    assert len(poses) == 5
    t, t0 = 1.55, time.monotonic()
    while time.monotonic() - t0 < 3 * pause:  # broken scans only, for longer than pause_wall; inputs go on
        slam._on_scan(table_to_pointcloud2(t, 'laser', {'r': np.ones(2)}))  # no range/bearing: refused
        slam._on_input(inputs_to_twist(t, 1.0, 0.0))
        t += 0.001
        time.sleep(0.005)
    assert slam.n_bad_scans > 0
    n = len(poses)
    for k in range(10):  # valid again, each scan arriving after the input 50 ms later (laser latency)
        slam._on_input(inputs_to_twist(t + 0.1 * k + 0.05, 1.0, 0.0))
        slam._on_scan(_scan(t + 0.1 * k))
    assert len(poses) - n == 10, slam.refusals.by_key()

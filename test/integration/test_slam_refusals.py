"""A scan the slam node refuses leaves its stream merger and filter untouched: a broken scan (no usable
observation, whatever its stamp) must neither advance the scan stream's stamp nor reach the filter,
or every valid scan after it is refused as "time went backwards" and the node publishes nothing more."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from track_msgs_py.convert import inputs_to_twist, scan_to_pointcloud2
from track_nodes.fuzz.generate import Fuzzer
from track_nodes.slam.slam import SlamNode

pytestmark = pytest.mark.integration

TREES = np.array([[10.0, 1.0], [12.0, 2.0], [15.0, 1.5]])


def _slam(ros):
    """A slam node fed by calling its callbacks (deterministic); poses captured instead of published."""
    slam = ros.add(SlamNode(context=ros.context))
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

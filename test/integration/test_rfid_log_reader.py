"""rfid_log_reader in-process: the shipped example walk replayed on the topics of rfid_reader, on the node's clock.

- Every action of the log answered once, in order, with the results the core replay gives on the same log
  (so the same as ``track-experiment rfid-reader --set file=``), a phase cloud per MOVE with its reads
  and the step's stamp, the truth pose and status after each action.
- Replay at 4× on the wall clock: the stamps are 1/4 of the log's times apart.
- A bad log or no file stops the node at start with one line naming the row and column.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import PointCloud2

from track_core.rfid.log import LogReplay, read_log
from track_core.rfid.protocol import CommandKind
from track_core.rfid.signal import UnwrapConfig
from track_msgs import msg as tm
from track_msgs_py.clouds import pointcloud2_to_table
from track_msgs_py.qos import ESTIMATE_QOS
from track_msgs_py.records.rfid import RfidStep, RfidUserStatus
from track_msgs_py.stamps import stamp_to_sec
from track_msgs_py.topics import RFID_PHASE, RFID_STEP, RFID_USER_POSE, RFID_USER_STATUS
from track_nodes.base import ParameterError
from track_nodes.rfid.rfid_log_reader import RfidLogReaderNode

TYPES = {RFID_STEP: tm.RfidStep, RFID_PHASE: PointCloud2, RFID_USER_POSE: PoseStamped,
         RFID_USER_STATUS: tm.RfidUserStatus}
RATE = 4.0


def _sink(ros) -> dict[str, list]:
    node = ros.add(Node('rfid_sink', context=ros.context))
    msgs: dict[str, list] = {t: [] for t in TYPES}
    for topic, cls in TYPES.items():
        node.create_subscription(cls, topic, msgs[topic].append, ESTIMATE_QOS)
    return msgs


def _node(ros, **params):
    return ros.add(RfidLogReaderNode(context=ros.context,
                                     parameter_overrides=[Parameter(k, value=v) for k, v in params.items()]))


def test_the_example_walk_is_replayed_on_the_reader_topics(ros, repo):
    example = repo / 'data/rfid/example-walk.csv'
    msgs = _sink(ros)
    node = _node(ros, file=str(example), rate=RATE, wait_for_subscribers=1)
    log = read_log(example)
    n = len(log.actions)
    assert ros.spin_until(lambda: len(msgs[RFID_STEP]) >= n and len(msgs[RFID_PHASE]) >= len(log.moves)
                          and len(msgs[RFID_USER_STATUS]) >= n and len(msgs[RFID_USER_POSE]) >= n, timeout=60), \
        {t: len(v) for t, v in msgs.items()}
    assert node.replay.done
    # the core replay of the same log, the same processing: the same results, exactly
    ref = LogReplay(log, UnwrapConfig.real_reader(log.phase_model()))
    want = ref.take_due(math.inf, 1.0)
    steps = [RfidStep.from_msg(m) for m in msgs[RFID_STEP]]
    assert [s.seq for s in steps] == list(range(1, n + 1))
    assert [s.result() for s in steps] == [w.result for w in want]
    assert [s.kind for s in steps].count(CommandKind.TURN) == 1 and all(s.ok for s in steps)
    assert steps[4].turn == pytest.approx(math.radians(20.0))
    # node time: stamps follow the log's action ends at 4x
    stamps = np.array([stamp_to_sec(m.header.stamp) for m in msgs[RFID_STEP]])
    ends = np.array([a.stream.t_end for a in log.actions])
    np.testing.assert_allclose(np.diff(stamps), np.diff(ends) / RATE, atol=1e-6)
    # one phase cloud per MOVE, with its reads and the stamp of its step result
    moves = [m for m, s in zip(msgs[RFID_STEP], steps, strict=True) if s.kind is CommandKind.MOVE]
    for cloud, step, a in zip(msgs[RFID_PHASE], moves, log.moves, strict=True):
        table = pointcloud2_to_table(cloud)
        assert len(table['t']) == len(a.stream) == RfidStep.from_msg(step).n_reads
        np.testing.assert_allclose(table['phase'], a.stream.phase, atol=1e-6)
        np.testing.assert_allclose(table['carrier_mhz'], a.stream.carrier_hz / 1e6, atol=1e-3)
        assert cloud.header.stamp == step.header.stamp
    # the log's truth after each action
    status = [RfidUserStatus.from_msg(m) for m in msgs[RFID_USER_STATUS]]
    assert len(status) == len(msgs[RFID_USER_POSE]) == n
    assert (status[-1].steps, status[-1].turns) == (8, 1)
    assert status[-1].x == pytest.approx(log.actions[-1].pose[0])
    assert status[-1].distance_m == pytest.approx(8 * 0.2, abs=0.02)


def test_a_bad_log_stops_the_node_with_one_line(ros, tmp_path, repo):
    text = (repo / 'data/rfid/example-walk.csv').read_text().splitlines()
    fields = text[20].split(',')
    fields[0] = '-1.0'                                # a read before the row above it
    text[20] = ','.join(fields)
    bad = tmp_path / 'bad.csv'
    bad.write_text('\n'.join(text) + '\n')
    with pytest.raises(ParameterError, match=r"bad.csv: line 21, column time: -1 s is before .* \(line 20\)") as exc:
        RfidLogReaderNode(context=ros.context, parameter_overrides=[Parameter('file', value=str(bad))])
    assert '\n' not in str(exc.value)
    with pytest.raises(ParameterError, match='parameter file is empty'):
        RfidLogReaderNode(context=ros.context)

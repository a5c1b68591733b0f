"""rfid_llrp_reader in-process against an LLRP reader on localhost (``llrp_rig``: llrpkit's emulator, phases
scripted), over real sllurp and real DDS.

- A MOVE command is answered with the reads that arrived during ``move_s``: its dφ is the scripted phase
  change (LLRP sign: the phase rises, dφ > 0; 8 rad/s over 0.5 s = 4 rad, through a wrap, on a reader
  hopping over 8 channels every 0.2 s), published as a phase cloud and a step result.
- The reader goes away and comes back on the same port: the node counts the drop, reconnects by itself,
  and the next MOVE is answered from the new connection's reads.
- "Connected" only after the LLRP handshake: the link logs it when the reader has answered
  GET_READER_CAPABILITIES, never at the TCP connect.
- A TCP listener that never speaks LLRP (here one that accepts and stays silent) is refused within
  ``handshake_s`` with one warning line, however often it is retried; the node is never ``up``.
- No host: the node stops at start with one line.
"""

from __future__ import annotations

import importlib.util
import socket
import time
from pathlib import Path

import pytest
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import PointCloud2

from track_core.rfid.protocol import Command, CommandKind
from track_msgs import msg as tm
from track_msgs_py.qos import ESTIMATE_QOS
from track_msgs_py.records.rfid import RfidCommand, RfidStep
from track_msgs_py.topics import RFID_COMMAND, RFID_PHASE, RFID_STEP
from track_nodes.base import ParameterError
from track_nodes.rfid.llrp import LlrpLink, reader_config
from track_nodes.rfid.rfid_llrp_reader import RfidLlrpReaderNode

pytestmark = pytest.mark.integration

_spec = importlib.util.spec_from_file_location('llrp_rig', Path(__file__).with_name('llrp_rig.py'))
llrp_rig = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(llrp_rig)   # a test-support module beside this file (the suite imports by path)

OMEGA = 8.0          # rad/s of scripted phase change
MOVE_S = 0.5
CHANNELS_MHZ = [902.75 + 0.5 * i for i in range(8)]


@pytest.fixture
def rig():
    r = llrp_rig.ReaderRig(OMEGA, len(CHANNELS_MHZ), 0.2)
    r.start()
    yield r
    r.close()


def _run(ros, rig):
    node = ros.add(RfidLlrpReaderNode(context=ros.context, parameter_overrides=[
        Parameter('host', value='127.0.0.1'), Parameter('port', value=rig.port), Parameter('move_s', value=MOVE_S),
        Parameter('channels_mhz', value=CHANNELS_MHZ), Parameter('carrier_hz', value=CHANNELS_MHZ[0] * 1e6),
        Parameter('retry_s', value=0.2)]))
    probe = ros.add(Node('llrp_probe', context=ros.context))
    got: dict[str, list] = {RFID_STEP: [], RFID_PHASE: []}
    probe.create_subscription(tm.RfidStep, RFID_STEP, got[RFID_STEP].append, ESTIMATE_QOS)
    probe.create_subscription(PointCloud2, RFID_PHASE, got[RFID_PHASE].append, ESTIMATE_QOS)
    pub = probe.create_publisher(tm.RfidCommand, RFID_COMMAND, ESTIMATE_QOS)
    return node, got, pub


def _move(ros, node, got, pub, seq: int) -> RfidStep:
    """Send MOVE ``seq`` (again until answered: the guidance's resend) and return its step result."""
    msg = RfidCommand.from_command(Command(CommandKind.MOVE, seq=seq)).to_msg(0.0)

    def answered() -> bool:
        if not any(RfidStep.from_msg(m).seq == seq for m in got[RFID_STEP]):
            pub.publish(msg)
            return False
        return True

    assert ros.spin_until(answered, timeout=60), (node.link.connects, node.link.failures, node.link.last_error)
    return next(RfidStep.from_msg(m) for m in got[RFID_STEP] if RfidStep.from_msg(m).seq == seq)


def test_a_move_is_answered_from_the_live_reads(ros, rig):
    node, got, pub = _run(ros, rig)
    assert ros.spin_until(lambda: node.link.up and node.live.idle_reads > 100, timeout=60), node.link.last_error
    step = _move(ros, node, got, pub, 1)
    assert step.ok and step.kind is CommandKind.MOVE, step
    assert step.dphi == pytest.approx(OMEGA * MOVE_S, abs=0.3)   # 4 rad, through a wrap and 2-3 hops
    assert 100 <= step.n_reads <= 200                             # 300 reads/s for 0.5 s
    assert ros.spin_until(lambda: len(got[RFID_PHASE]) >= 1, timeout=30)
    assert got[RFID_PHASE][0].width == step.n_reads and node.epc == llrp_rig.EPC


def test_a_reader_that_goes_away_and_comes_back_is_reconnected(ros, rig):
    node, got, pub = _run(ros, rig)
    assert ros.spin_until(lambda: node.link.up and node.live.idle_reads > 0, timeout=60), node.link.last_error
    rig.stop()
    assert ros.spin_until(lambda: node.link.drops >= 1 and not node.link.up, timeout=60)
    ros.spin_until(lambda: node.link.failures >= 2, timeout=30)   # it keeps trying while the reader is away
    assert node.link.failures >= 2
    idle = node.live.idle_reads
    rig.start()                                                   # back on the same port
    assert ros.spin_until(lambda: node.link.connects >= 2 and node.link.up, timeout=60), node.link.last_error
    assert ros.spin_until(lambda: node.live.idle_reads > idle + 100, timeout=60)   # its inventory has started
    step = _move(ros, node, got, pub, 1)
    assert step.ok and step.dphi == pytest.approx(OMEGA * MOVE_S, abs=0.3), step


def test_no_host_stops_the_node_with_one_line(ros):
    with pytest.raises(ParameterError, match='parameter host is empty') as exc:
        RfidLlrpReaderNode(context=ros.context)
    assert '\n' not in str(exc.value)


@pytest.fixture
def silent():
    """A TCP port that accepts connections (the kernel completes them) and never says a word."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    sock.bind(('127.0.0.1', 0))
    sock.listen(8)
    yield sock.getsockname()[1]
    sock.close()


def _poll_until(link: LlrpLink, predicate, timeout: float) -> bool:
    """Drive ``link.poll`` (the node's timer) until ``predicate()`` or ``timeout`` s."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and not predicate():
        link.poll(time.time())
        time.sleep(0.01)
    return bool(predicate())


def test_connected_is_said_only_after_the_llrp_handshake(rig):
    from sllurp.llrp import LLRPReaderState

    said: list[tuple[str, int]] = []
    link = LlrpLink('127.0.0.1', rig.port, reader_config([1], 0.0), retry_s=0.2, handshake_s=10.0,
                    log=lambda line: said.append((line, link.client.llrp.state if link.client else -1)))
    try:
        assert _poll_until(link, lambda: link.up and link.queue.qsize() > 10, 60), link.last_error
        lines = [(line, state) for line, state in said if line.startswith('connected')]
        assert len(lines) == 1 and link.connects == 1 and link.refusals == 0, said
        line, state = lines[0]
        assert 'LLRP capabilities answered' in line
        assert state >= LLRPReaderState.STATE_CONNECTED   # the reader's answer had come when it was said
    finally:
        link.close()


def test_a_listener_that_never_speaks_llrp_is_refused_with_one_line(silent):
    said, warned = [], []
    link = LlrpLink('127.0.0.1', silent, reader_config([1], 0.0), retry_s=0.1, handshake_s=0.5,
                    log=said.append, warn=warned.append)
    try:
        start = time.monotonic()
        assert _poll_until(link, lambda: link.refusals >= 1, 30)
        assert time.monotonic() - start < 0.5 + 10.0          # the handshake time plus a busy machine's slack
        assert _poll_until(link, lambda: link.refusals >= 3, 30)   # retried, and refused again
        assert not link.up and link.connects == 0 and link.client is None
        assert not any(line.startswith('connected') for line in said), said
        assert len(warned) == 1 and '\n' not in warned[0], warned   # one line for the whole run of refusals
        assert f'127.0.0.1:{silent}' in warned[0] and 'no LLRP answer within 0.5 s' in warned[0]
    finally:
        link.close()


def test_the_node_refuses_a_silent_listener(ros, silent):
    node = ros.add(RfidLlrpReaderNode(context=ros.context, parameter_overrides=[
        Parameter('host', value='127.0.0.1'), Parameter('port', value=silent), Parameter('retry_s', value=0.1),
        Parameter('handshake_s', value=0.3)]))
    assert ros.spin_until(lambda: node.link.refusals >= 2, timeout=30), node.link.last_error
    assert not node.link.up and node.link.connects == 0
    assert node.link.last_error.startswith('refused: no LLRP answer within 0.3 s')

"""``rfid_log_reader``: a recorded walk (``track_core.rfid.log``) replayed on the topics of ``rfid_reader``.

The log ``file`` is read and checked at start (a bad row stops the node with the log's one-line refusal).
Each MOVE and TURN of the log is then answered when its end is due on the node's clock (``/clock`` under
``use_sim_time``): ``(t_end − first action's start) / rate`` after the replay began, checked by a timer
of period ``tick``. Published per action, as ``rfid_reader`` does (``track_nodes.rfid.reads``): ``/rfid/phase``
(a MOVE's reads; positions from the log's truth, else the origin), ``/rfid/user/pose``, ``/tf`` and
``/rfid/user/status`` when the log has the truth (our simulator writes it; a real walk has none), and
``/rfid/step`` last, ``seq`` = the action's place in the log. MOVEs go through the real-reader signal
processing (``relock_reads``, ``noise``) with the log's sign, wrap and reference carrier: the same dφ as
``track-experiment rfid-reader --set file=``.

A replay is not a search: the walk is what was recorded, so commands on ``/rfid/command`` are not
taken; ``rfid_guidance`` beside it only shows how the filter would follow the recorded steps.
``wait_for_subscribers``: the replay begins once each of those four topics has that many subscribers (0: at once),
so that a recorder or a test started at the same time misses nothing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from track_core.rfid.log import LogReplay, read_log
from track_core.rfid.signal import UnwrapConfig
from track_msgs_py.records.rfid import RfidUserStatus
from track_msgs_py.topics import RFID_PHASE, RFID_STEP, RFID_USER_POSE, RFID_USER_STATUS
from track_nodes.base import ParameterError, TrackNode, param
from track_nodes.rfid.reads import ReaderTopics


@dataclass
class RfidLogReaderParams:
    """Parameters of ``rfid_log_reader``."""

    file: str = param('', 'reader log to replay (CSV, track_core.rfid.log; required)')
    epc: str = param('', "the log's tag to replay (empty: the log's # epc:, or its only tag)")
    rate: float = param(1.0, 'replay speed: log seconds per node second', 1e-3, 1e3, live=True)
    relock_reads: int = param(5, 'signal processing: agreeing reads that re-lock after a phase step; 0 = never',
                              0, 1000)
    noise: str = param('robust', 'signal processing: robust (heavy-tailed noise learnt from the data), online '
                       '(Gaussian noise from the data) or fixed (the paper)', choices=('fixed', 'online', 'robust'))
    found_radius: float = param(0.2, 'with truth: found within this distance of the tag at the end of a MOVE [m]',
                                1e-3, 100.0)
    wait_for_subscribers: int = param(0, 'begin once each reader topic has this many subscribers (0: at once)', 0,
                                      100)
    tick: float = param(0.02, 'period of the timer that publishes due answers [node s]', 1e-3, 10.0)


READER_TOPICS = (RFID_PHASE, RFID_USER_POSE, RFID_USER_STATUS, RFID_STEP)


class RfidLogReaderNode(TrackNode):
    DEFAULT_NAME = 'rfid_log_reader'
    Params = RfidLogReaderParams
    p: RfidLogReaderParams

    def setup(self) -> None:
        p = self.p
        if not p.file:
            raise ParameterError('parameter file is empty: allowed a reader log (CSV, track_core.rfid.log)')
        try:
            log = read_log(p.file, epc=p.epc or None)
            unwrap = UnwrapConfig.real_reader(log.phase_model(), relock_reads=p.relock_reads, noise=p.noise)
        except (ValueError, OSError) as exc:
            raise ParameterError(f'parameter file={p.file!r}: {exc}') from None
        if not log.actions:
            raise ParameterError(f'parameter file={p.file!r}: the log has no MOVE or TURN event')
        self.replay = LogReplay(log, unwrap, p.found_radius)
        self.topics = ReaderTopics(self, log.carrier_hz)
        self.timer = self.create_timer(p.tick, self._tick)
        self.get_logger().info(log.describe())

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _tick(self) -> None:
        r = self.replay
        if r.done or (r.begin is None and min(self.count_subscribers(t) for t in READER_TOPICS)
                      < self.p.wait_for_subscribers):
            return
        for s in r.take_due(self._now(), self.p.rate):
            a = s.action
            truth = None
            if a.pose is not None:
                x, y, head = (float(v) for v in a.pose)
                truth = RfidUserStatus(a.seq, s.steps, s.turns, s.distance_m, 0, math.hypot(x, y), s.result.found,
                                       x, y, head if math.isfinite(head) else 0.0)
            self.topics.publish(r.due_at(a, self.p.rate), s.result, a.stream, a.duration, truth)
        if r.done:
            self.get_logger().info(f'replay over: {r.steps} MOVEs and {r.turns} TURNs of {r.log.source}')

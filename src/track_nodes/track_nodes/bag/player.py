"""``player``: replay a rosbag2 bag with its original timing, publishing ``/clock``.

Usage::

    track-play BAG [--rate R] [--loop] [--topics T ...] [--start-offset S] [--wait S]
    .venv/lib/track_nodes/player BAG ...          (same, through the ros2-run shim)
    ... --ros-args -p bag:=BAG -p rate:=2.0       (parameters directly)

- BAG: a bag directory, an .mcap file with summary, or a bag name (→ ``bags/BAG/``).
- A message of bag time t is published at wall time ``t0_wall + (t - t_start) / rate``, t_start the
  first message time plus ``--start-offset``; the raw CDR bytes unchanged.
- ``/clock`` carries bag time (each message's just before it, and every ``clock_period`` wall s in
  between; never backwards except when ``--loop`` restarts); a recorded ``/clock`` is not replayed.
- Publishers: reliable, keep-last 100; transient-local where every recorded publisher was.
- Before the first message: up to ``--wait`` s (default 2) for a subscription to every topic, then
  0.5 s; a ``/track/ready`` announcer is waited for up to ``READY_WAIT`` s more.
- The whole bag is validated first (``bag.integrity``, ``bag.playcheck``): a bad path, no bag, a
  truncated or corrupt .mcap, a CRC failure, a FIFO, a ``--rate`` outside
  ``RATE_MIN``..``RATE_MAX``, an unknown ``--topics`` entry, metadata disagreeing with the .mcap or
  nothing to play: one line on stderr, exit 2; wrong counts in ``metadata.yaml`` are a warning.
- Exit 0 when played (unless ``--loop``); SIGINT, SIGTERM, SIGHUP stop it alike, a cut playback ends
  with ``played K of N messages``. In full: docs/MODULES.md, "The player in full".
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from rclpy.clock import Clock as RosClock
from rclpy.clock import ClockType
from rclpy.duration import Duration
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock

from track_nodes.bag.api import BagError, msg_class, open_bag_checked, qos_is_transient_local
from track_nodes.bag.playcheck import plan_playback
from track_nodes.base import ParameterError, TrackNode, param, run_node
from track_nodes.base.cli import OneLineParser, cli_overrides
from track_nodes.base.ready import Announced

CLOCK_TOPIC = '/clock'
DEPTH = 100
SETTLE = 0.5  # wall seconds after all subscriptions matched (the subscribers' side matches later)
READY_WAIT = 30.0  # [wall s] for a subscribed TrackNode to announce itself (base/ready.py: it listens first)
ACK_TIMEOUT = 2.0
RATE_MIN, RATE_MAX = 1e-3, 1e3  # slower plays a 10 s bag for hours, faster only skips the timing


@dataclass
class PlayerParams:
    """Parameters of ``player``; a bad one is reported with the bag it was given for."""

    bag: str = param('', "bag directory or .mcap file (a name without '/' → bags/<name>/)")
    rate: float = param(1.0, 'playback speed factor (2 = twice as fast)', RATE_MIN, RATE_MAX)
    loop: bool = param(False, 'start again at the end, forever')
    topics: list[str] = param([''], 'topics to play (empty: all)')
    start_offset: float = param(0.0, 'skip this much bag time from the first message [s]', 0.0, 1e9)
    wait_subscribers: float = param(2.0, 'wait up to this long for a subscription on every topic [s]', 0.0, 3600.0)
    clock_period: float = param(0.01, 'wall interval between /clock messages between bag messages [s]', 1e-3, 10.0)

    @staticmethod
    def error_context(values) -> str | None:
        return str(resolve_bag(values['bag'])) if values.get('bag') else None


def resolve_bag(text: str) -> Path:
    path = Path(text)
    if '/' not in text and not path.exists() and (Path('bags') / text).exists():
        return Path('bags') / text
    return path


def wall_offsets(bag_times_ns: Sequence[int], start_ns: int, rate: float) -> list[float]:
    """Wall seconds after playback start at which each message is due: (t - start) / rate."""
    return [(t - start_ns) * 1e-9 / rate for t in bag_times_ns]


def _stamp(ns: int):
    from builtin_interfaces.msg import Time

    return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


class PlayerNode(TrackNode):
    DEFAULT_NAME = 'player'
    Params = PlayerParams
    p: PlayerParams  # the declared parameters (base/params.py)

    def __init__(self, exit_when_done: bool = False, **kw) -> None:
        super().__init__(**kw)
        self.reader = None
        self.exit_code = 0
        self.done = threading.Event()
        self._final_line: tuple[str, bool] | None = None
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        if not self.p.bag:
            raise ParameterError('no bag given: track-play BAG (or -p bag:=BAG)')
        self.path = resolve_bag(self.p.bag)
        self.reader = open_bag_checked(self.path)
        try:
            self._setup()
        except BaseException:
            self._close_reader()
            raise
        self.published = 0
        self.clock_pub = self.create_publisher(Clock, CLOCK_TOPIC, QoSProfile(depth=10))
        self.announced = Announced(self)
        self.publishers_by_topic = {}
        for topic, (msgtype, transient) in self.topic_info.items():
            qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=DEPTH, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL if transient else DurabilityPolicy.VOLATILE)
            self.publishers_by_topic[topic] = self.create_publisher(self.classes[msgtype], topic, qos,
                                                                    as_given=True)  # the recorded names
        self.exit_when_done = exit_when_done
        self.create_timer(0.05, self._exit_if_done, clock=RosClock(clock_type=ClockType.STEADY_TIME))
        self._thread = threading.Thread(target=self._run, name='player', daemon=True)
        self._thread.start()

    # -- validation -----------------------------------------------------------------------
    def _setup(self) -> None:
        reader, path = self.reader, self.path
        by_topic: dict[str, list] = {}
        for conn in reader.connections:
            by_topic.setdefault(conn.topic, []).append(conn)
        wanted = sorted({t if t.startswith('/') else '/' + t for t in self.p.topics if t})
        unknown = [t for t in wanted if t not in by_topic]
        if unknown:
            raise BagError(f'{path}: --topics {", ".join(unknown)} not in the bag '
                           f'(it has: {", ".join(sorted(by_topic)) or "no topics"})')
        topics = [t for t in (wanted or sorted(by_topic)) if t != CLOCK_TOPIC]
        self.topic_info: dict[str, tuple[str, bool]] = {}
        self.classes: dict[str, type] = {}
        for topic in topics:
            conns = by_topic[topic]
            types = {c.msgtype for c in conns}
            if len(types) > 1:
                raise BagError(f'{path}: topic {topic} has several types {sorted(types)}; not supported')
            msgtype = types.pop()
            try:
                self.classes.setdefault(msgtype, msg_class(msgtype))
            except ValueError as exc:
                raise BagError(f'{path}: topic {topic}: {exc}') from None
            qos = [q for c in conns for q in c.ext.offered_qos_profiles]
            self.topic_info[topic] = (msgtype, qos_is_transient_local(qos))
        self.connections = [c for t in topics for c in by_topic[t]]
        self.start_ns = reader.start_time + round(self.p.start_offset * 1e9)
        plan = plan_playback(reader, path, topics, self.start_ns, self.p.start_offset)  # reads every message once
        for line in plan.warnings:
            self.get_logger().warning(line)
        self.to_play = plan.to_play
        self.get_logger().info(
            f'{path}: {sum(plan.counts.values())} messages, {reader.duration * 1e-9:.3f} s; playing {self.to_play} '
            f'messages on {len(topics)} topics at rate {self.p.rate:g}' + (' in a loop' if self.p.loop else ''))

    # -- playback -------------------------------------------------------------------------
    def _wait_for_subscribers(self) -> None:
        deadline = time.monotonic() + self.p.wait_subscribers
        pubs = list(self.publishers_by_topic.values())
        while not all(pub.get_subscription_count() > 0 for pub in pubs):
            if time.monotonic() >= deadline or self._stop.wait(0.02):
                return
        deadline = time.monotonic() + READY_WAIT
        while self.announced.unready_subscribers(list(self.publishers_by_topic)):
            if time.monotonic() >= deadline or self._stop.wait(0.05):
                break
        self._stop.wait(SETTLE)

    def _final(self, line: str, error: bool = False) -> None:
        """The playback thread's last line: the main thread logs it (``_log_final``), so the rcl logger is
        never called from this thread while the main one tears the node down."""
        self._final_line = (line, error)

    def _log_final(self) -> None:
        """Log the playback's last line once, from the main thread (``_exit_if_done``, ``destroy_node``)."""
        final, self._final_line = self._final_line, None
        if final is None:
            return
        if self.context.ok():
            (self.get_logger().error if final[1] else self.get_logger().info)(final[0])
        else:  # after shutdown the logger can no longer reach /rosout and complains
            print(f'[{"ERROR" if final[1] else "INFO"}] [{self.get_name()}]: {final[0]}', file=sys.stderr)

    def _publish_clock(self, ns: int) -> None:
        if ns > self._last_clock:
            self._last_clock = ns
            self.clock_pub.publish(Clock(clock=_stamp(ns)))

    def _run(self) -> None:
        try:
            self._wait_for_subscribers()
            while not self._stop.is_set():
                self._play_once()
                if not self.p.loop:
                    break
            for pub in self.publishers_by_topic.values():
                if self._stop.is_set():
                    break
                pub.wait_for_all_acked(Duration(seconds=ACK_TIMEOUT))
            self._final(self._played())
        except Exception as exc:  # a failing playback thread must not hang the node
            if self._stop.is_set() or not self.context.ok():  # a stop signal shut the context down mid-publish
                self._final(self._played())
            else:
                self.exit_code = 1
                self._final(f'playback of {self.path} failed: {type(exc).__name__}: {exc}', error=True)
        finally:
            self.done.set()

    def _play_once(self) -> None:
        rate, period = self.p.rate, self.p.clock_period
        self._last_clock = -1
        self._publish_clock(self.start_ns)
        wall0 = time.monotonic()
        for conn, t, data in self.reader.messages(connections=self.connections, start=self.start_ns):
            due = wall0 + (t - self.start_ns) * 1e-9 / rate
            while (now := time.monotonic()) < due:
                if self._stop.wait(min(due - now, period)):
                    return
                bag_now = self.start_ns + round((time.monotonic() - wall0) * rate * 1e9)
                self._publish_clock(min(bag_now, t - 1))
            if self._stop.is_set():
                return
            self._publish_clock(t)
            self.publishers_by_topic[conn.topic].publish(data)
            self.published += 1

    def _played(self) -> str:
        """The final line: a playback cut short says how much of it was played."""
        if self.p.loop or self.published == self.to_play:
            return f'played {self.published} messages from {self.path}'
        return f'played {self.published} of {self.to_play} messages from {self.path} (stopped before the end)'

    def _exit_if_done(self) -> None:
        """Once the playback is done: its last line, and with ``exit_when_done`` the end of the process."""
        if self.done.is_set():
            self._log_final()
            if self.exit_when_done:
                self.context.try_shutdown()  # ends run_node's spin; destroy_node follows

    def _close_reader(self) -> None:
        reader, self.reader = self.reader, None
        if reader is not None:
            reader.close()

    def destroy_node(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
        self._log_final()
        self._close_reader()
        super().destroy_node()


def parse_cli(argv: Sequence[str]) -> list[Parameter]:
    """Non-ROS CLI arguments → parameter overrides (``--ros-args`` are left to rclpy)."""
    ap = OneLineParser(prog='track-play', description='Replay a bag with its timing and /clock.')
    ap.add_argument('bag', nargs='?', help="bag directory or .mcap (a name without '/' → bags/NAME/)")
    ap.add_argument('--rate', type=float, default=None,
                    help=f'speed factor, {RATE_MIN:g} to {RATE_MAX:g} (default 1)')
    ap.add_argument('--loop', action='store_true', help='play again and again')
    ap.add_argument('--topics', nargs='+', default=None, metavar='T', help='play only these topics')
    ap.add_argument('--start-offset', type=float, default=None, metavar='S',
                    help='start S seconds of bag time after the first message')
    ap.add_argument('--wait', '--wait-subscribers', dest='wait_subscribers', type=float, default=None, metavar='S',
                    help='wait up to S s for a subscriber on every topic before the first message (default 2)')
    return cli_overrides(ap, argv, {'bag': 'bag', 'rate': 'rate', 'loop': 'loop', 'topics': 'topics',
                                    'start_offset': 'start_offset', 'wait_subscribers': 'wait_subscribers'})


def main(argv: Sequence[str] | None = None) -> int:
    args = list(sys.argv if argv is None else argv)
    overrides = parse_cli(args)
    return run_node(PlayerNode, args, parameter_overrides=overrides or None, exit_when_done=True)


if __name__ == '__main__':
    raise SystemExit(main())

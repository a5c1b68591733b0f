"""``clock``: the launcher's /clock driver as a node of its own, for ``ros2 launch`` and hand-made graphs.

Publishes ``/clock`` at ``rate`` × real time from ``epoch`` ('now': the whole minute of wall time;
whole seconds since 1970; or an ISO date in UTC), in the launcher's steps
(``track_nodes.launch.pacing``), and stops at ``duration`` seconds of node time (0: runs until
stopped). It runs on the steady clock whatever ``use_sim_time`` says (it is the one that publishes
/clock); ``use_sim_time:=true`` is refused.

Before the first step it waits, as the launcher does with one process per node, until every node
named in ``wait_for`` (comma-separated) has announced itself on ``/track/ready``, every /clock
subscription of the graph has matched its publisher and, with ``record_regex``, the ``recorder``
has subscribed to every topic it records; then it holds /clock at the epoch for ``settle`` wall
seconds, so every node's first reading, which fixes its step origin, is the epoch itself. Nodes
started without a /clock (a ``use_sim_time`` node before any /clock reads 0) never fix their origin
at different moments this way.

After the last step it waits until the work of that step is done (no topic of ``record_regex``,
or of the whole graph without it, delivered for ``tuning.QUIET`` wall seconds, at most
``tuning.DRAIN_MAX``), plus ``tuning.GRACE``, then exits with code 0: ``ros2 launch`` files take
that as the end of the run (``launch/ros2_launch.py``). A deadline for the nodes to come up that
runs out, or a second /clock publisher, is one line and exit code 1.

With ``end_after`` (node names, comma-separated) it publishes no /clock at all: a replay's player
publishes the bag's. It waits for ``wait_for`` as above, then until every node of ``end_after`` has
left the graph (the player exits once its bag is played), drains the same way and exits 0, so a
``ros2 launch`` of a replay ends when the bag has been played, as the launcher's run does, instead
of after its whole ``duration`` of wall time.
"""

from __future__ import annotations

import enum
import time
from dataclasses import dataclass

from track_nodes.base import TrackNode, param
from track_nodes.base.epoch import EpochError, parse_epoch
from track_nodes.launch.graph import GraphWatch, listing, ready_deadline
from track_nodes.launch.pacing import Cadence, clock_step, epoch_line, epoch_now, node_time
from track_nodes.launch.tuning import CLOCK_TICK, DRAIN_MAX, GRACE, QUIET, SETTLE_PROCESSES, WATCH_EVERY

NS = 1_000_000_000


@dataclass
class ClockParams:
    """Parameters of ``clock``."""

    rate: float = param(1.0, 'speed of /clock against the wall clock (x real time)', 1e-3, 1e4)
    epoch: str = param('now', "node time of the first /clock: 'now' (the whole minute of wall time), "
                       'whole seconds since 1970, or an ISO date (UTC)')
    duration: float = param(0.0, 'node seconds after the epoch at which /clock stops and the node exits; '
                            '0 = never', 0.0, 1e9)
    wait_for: str = param('', 'comma-separated node names that must be up (/track/ready) before /clock starts')
    record_regex: str = param('', "topics the node 'recorder' must have subscribed to before /clock starts "
                              "(regular expression; '' = no recorder); also the topics watched for the end")
    settle: float = param(SETTLE_PROCESSES, 'wall seconds /clock is held at the epoch once every node is up',
                          0.0, 600.0)
    end_after: str = param('', 'comma-separated node names: publish no /clock; once they have all left the graph '
                           '(a player whose bag is played), drain and exit')


class Phase(enum.Enum):
    WAITING = 'waiting for the nodes'
    SETTLING = 'held at the epoch'
    RUNNING = 'running'
    FOLLOWING = 'waiting for the end_after nodes to leave'
    DRAINING = 'draining'


class ClockNode(GraphWatch, TrackNode):
    """Publishes /clock at ``rate`` × real time from ``epoch`` until ``duration``, once ``wait_for`` is up."""

    DEFAULT_NAME = 'clock'
    Params = ClockParams
    p: ClockParams

    def setup(self) -> None:
        if self.get_parameter('use_sim_time').value:
            raise ValueError('use_sim_time: must be false (this node publishes /clock; it runs on the steady clock)')
        try:
            self.epoch = parse_epoch(self.p.epoch, 'epoch')
        except EpochError as exc:
            raise ValueError(str(exc)) from None
        self.names = [n.strip() for n in self.p.wait_for.split(',') if n.strip()]
        self.end_after = [n.strip() for n in self.p.end_after.split(',') if n.strip()]
        self.names += [n for n in self.end_after if n not in self.names]
        if self.p.record_regex:
            self.names.append('recorder')
        self.watch_graph()
        self.cadence = Cadence()  # fed by the watched topics (graph.GraphWatch.watch)
        self.held = 0  # clock ticks held back for a topic that was behind
        self.exit_code = 0
        self.step, self.wall_step = clock_step(self.p.rate)
        self.duration = self.p.duration or None
        self.k = 0
        self.phase = Phase.WAITING
        timeout, self.deadline_why = ready_deadline(len(self.names), True)
        self.phase_end = time.monotonic() + timeout
        self.t0 = 0.0
        self.timer = self.create_timer(CLOCK_TICK, self._tick, clock=self._steady)

    # -- the phases ---------------------------------------------------------------------------
    def _tick(self) -> None:
        now = time.monotonic()
        if self.phase is Phase.WAITING:
            self._wait(now)
        elif self.phase is Phase.SETTLING:
            self.publish_clock(self._epoch_ns())
            if now >= self.phase_end:
                self.phase, self.t0 = Phase.RUNNING, now
                self.timer.timer_period_ns = round(self.wall_step * NS)
                self.get_logger().info(f'/clock running at {self.p.rate:g}x'
                                       + (f' for {self.duration:g} s' if self.duration else ''))
        elif self.phase is Phase.RUNNING:
            self._run(now)
        elif self.phase is Phase.FOLLOWING:
            self.watch(self.p.record_regex or '.*')  # subscribed before the end, so the drain sees the last work
            if not self.present(self.end_after):
                self.get_logger().info(f'{listing(self.end_after)} done (left the graph): draining')
                self._drain(now)
        elif now - self.last_message >= QUIET + GRACE or now >= self.phase_end:
            what = f'/clock stopped at {self.duration:g} s' if not self.end_after else 'the replay is over'
            self.get_logger().info(f'{what}; the graph is quiet: done ({self.held} ticks held for a topic behind)')
            self.context.try_shutdown()  # ends the spin; the process exits 0

    def present(self, names: list[str]) -> list[str]:
        """Those of ``names`` (node names, in any namespace) that are in the graph now."""
        here = {n for n, _ in self.get_node_names_and_namespaces()}
        return [n for n in names if n.rsplit('/', 1)[-1] in here]

    def _drain(self, now: float) -> None:
        """The last step is out (or the replay over): wait until the watched topics are quiet."""
        self.watch(self.p.record_regex or '.*')
        self.phase, self.phase_end = Phase.DRAINING, now + DRAIN_MAX
        self.last_message = now
        self.timer.timer_period_ns = round(0.1 * NS)

    def _wait(self, now: float) -> None:
        missing = self.nodes_missing(self.names)
        if missing:
            what = f'the announcement of {listing(missing)} ({len(missing)} of {len(self.names)} nodes)'
        elif self.p.record_regex and (unrecorded := self.topics_unrecorded(self.p.record_regex, 'recorder')):
            what = f'the recorder to subscribe to {listing(unrecorded)}'
        elif not self.end_after and (unmatched := self.clock_unmatched()):
            what = f'{unmatched} /clock subscription(s) to match'
        elif self.end_after:
            self.phase = Phase.FOLLOWING
            self.timer.timer_period_ns = round(0.5 * NS)
            self.get_logger().info(f'every node is up; publishing no /clock: the run ends once '
                                   f'{listing(self.end_after)} has left the graph')
            return
        else:
            self.phase, self.phase_end = Phase.SETTLING, now + self.p.settle
            self.get_logger().info(epoch_line(self._epoch_s(), 'epoch') + f'; held for {self.p.settle:g} s')
            return
        if now > self.phase_end:
            self._fail(f'not ready in time ({self.deadline_why}): waiting for {what}')

    def _run(self, now: float) -> None:
        if self.k % WATCH_EVERY == 0:
            self.watch(self.p.record_regex or '.*')  # topics whose traffic tells when the work is done
            if (other := self.count_publishers('/clock') - 1) > 0:
                self._fail(f'{other} other /clock publisher(s) in this ROS domain')
                return
        t = node_time(self.k, self.step, self.duration)
        t_ns = self._epoch_ns() + round(t * NS)
        if self.k and self.cadence.holding(t_ns, now) is not None:
            self.held += 1
            return  # a periodic topic of another process is a step behind (pacing.Cadence)
        self.publish_clock(t_ns)
        if self.duration is not None and t >= self.duration:
            self._drain(now)
            return
        self.k += 1

    def _fail(self, line: str) -> None:
        self.get_logger().error(line)
        self.exit_code = 1
        self.context.try_shutdown()

    def _epoch_s(self) -> int:
        if self.epoch is None:
            self.epoch = epoch_now()
        return self.epoch

    def _epoch_ns(self) -> int:
        return self._epoch_s() * NS

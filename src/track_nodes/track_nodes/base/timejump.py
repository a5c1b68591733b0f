"""Time jumps of a node's clock: what the node keeps in time order is reset, as tf2 clears its buffer.

Under ``use_sim_time`` the clock follows ``/clock``, and ``/clock`` goes back whenever a player
restarts a bag (``track-play --loop``) or a simulator is reset. Every stamp watermark, filter,
window and lock-step gate then holds times of a run that is over: each later message would be
refused as "time went backwards" and the node would never estimate again. A forward jump beyond
``FORWARD_JUMP`` (the input policy's default horizon) leaves filters predicting over a gap no model
covers; it is treated the same way.

``watch_time_jumps(node)`` registers an rclpy jump callback (``Clock.create_jump_callback`` with a
``JumpThreshold``) that calls ``node.reset_time_state()`` on such a jump. The hook returns the
names of what it reset (``TrackNode``'s default resets nothing, and then nothing is logged), and
the watcher logs one line, e.g. ``clock jumped back 9.9 s (10.0 s -> 0.1 s): reset tracker, stamp
watermarks``. The first ``/clock`` after start (0 -> bag time) is not a jump: nothing is kept yet.
The callback runs inside the executor's ``/clock`` callback, so it never races a message callback
of a single-threaded executor. A message of the old run can still be queued when the reset happens
(``/clock`` and the data are different topics); stamped near the end of that run, it lies ahead of
the new clock, and the node's look-ahead tolerance (``InputPolicy.lead``) refuses it, so it cannot
seed the new run with an old time.
"""

from __future__ import annotations

from collections.abc import Iterable

from rclpy.clock import ClockChange, JumpThreshold
from rclpy.duration import Duration

FORWARD_JUMP = 60.0  # a forward jump longer than this [s] resets too (InputPolicy.horizon's default)
BACKWARD_JUMP_NS = 1  # any step back of the clock resets


def jump_line(delta: float, now: float, what: Iterable[str]) -> str | None:
    """The one log line of a jump of ``delta`` s that ended at ``now`` s, or ``None`` when nothing was reset."""
    what = [w for w in what if w]
    if not what:
        return None
    direction = 'back' if delta < 0 else 'forward'
    return f'clock jumped {direction} {abs(delta):.3g} s ({now - delta:.9g} s -> {now:.9g} s): reset {", ".join(what)}'


class TimeJumpWatch:
    """A node's jump callback; ``jumps`` counts the jumps that reset something."""

    def __init__(self, node, forward: float = FORWARD_JUMP) -> None:
        self.node = node
        self.jumps = 0
        threshold = JumpThreshold(min_forward=Duration(nanoseconds=round(forward * 1e9)),
                                  min_backward=Duration(nanoseconds=-BACKWARD_JUMP_NS), on_clock_change=False)
        self.handle = node.get_clock().create_jump_callback(threshold, post_callback=self._on_jump)

    def _on_jump(self, jump) -> None:
        if jump.clock_change not in (ClockChange.ROS_TIME_NO_CHANGE, ClockChange.SYSTEM_TIME_NO_CHANGE):
            return
        now_ns = self.node.get_clock().now().nanoseconds
        delta_ns = jump.delta.nanoseconds
        if now_ns - delta_ns <= 0:  # the first /clock: nothing was kept on the old time
            return
        line = jump_line(delta_ns * 1e-9, now_ns * 1e-9, self.node.reset_time_state() or ())
        if line is not None:
            self.jumps += 1
            self.node.get_logger().warning(line)

    def close(self) -> None:
        self.handle.unregister()


def watch_time_jumps(node) -> TimeJumpWatch:
    return TimeJumpWatch(node)

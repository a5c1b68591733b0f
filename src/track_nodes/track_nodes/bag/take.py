"""Taking every message a subscription holds in one callback: the recorder's batching.

rclpy's executors deliver one message per callback, and each delivery costs a pass of the
executor (wait set, ready list, task): on the SingleThreadedExecutor ~170 µs here (a bare raw
subscription took 5.8k msgs/s in ``track-bench recorder``), 25× the rosbags ``Writer``'s ~7 µs
per message (148k/s). So when the executor calls the recorder with one message, the recorder
takes the ones queued behind it itself, up to a limit (so the flush and discovery timers and the
other topics still get their turn), through the subscription's own ``take_message`` (what the
executors call; raw bytes and message info). Measured (bursts of 5000 716-B Odometry): 81k/s, 13×
the bare subscription, 0.54 of the Writer alone. Kept the SingleThreadedExecutor: the
EventsExecutor (bare: 184k/s) fails on message-info callbacks, which loss counting needs;
MultiThreaded: 2.2k/s bare, 19-30k/s batched. A writer thread fed by a queue gave 76-83k/s against
85-125k/s inline (the GIL: hand-offs, no parallel work).
"""

from __future__ import annotations

from typing import Any


def can_take(sub: Any) -> bool:
    """True if ``sub`` has the handle method that ``take_pending`` relies on (rclpy 7.x)."""
    return callable(getattr(getattr(sub, 'handle', None), 'take_message', None))


def take_pending(sub: Any, limit: int) -> list[tuple[bytes, dict]]:
    """Up to ``limit`` (raw message, message info) pairs waiting in ``sub``; [] once it is destroyed."""
    from rclpy.exceptions import InvalidHandle

    out: list[tuple[bytes, dict]] = []
    try:
        handle = sub.handle
        with handle:  # the handle stays valid while we take (as in the executors)
            take, msg_type = handle.take_message, sub.msg_type
            for _ in range(limit):
                got = take(msg_type, True)
                if got is None:
                    break
                out.append(got)
    except InvalidHandle:
        pass
    return out


class BeforeClock:
    """Messages taken under ``use_sim_time`` before the first /clock (transient-local ones: /tf_static,
    a layout), held until the clock runs and written then with its first reading as their log time,
    not 0: a bag whose clock starts at an epoch must not begin in 1970. The caller holds its lock."""

    def __init__(self) -> None:
        self.held: list[tuple[Any, bytes]] = []  # (connection, CDR)

    def hold(self, conn: Any, raws: list[bytes]) -> None:
        self.held += [(conn, raw) for raw in raws]

    def release(self, write: Any, now: int) -> None:
        for conn, raw in self.held:
            write(conn, now, raw)
        self.held = []

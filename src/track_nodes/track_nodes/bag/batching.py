"""Taking every message a subscription holds in one callback: the recorder's batching.

rclpy's executors deliver one message per callback, and each delivery costs a pass of the
executor (wait set, ready list, task), many times what the rosbags ``Writer`` spends on a message.
So when the executor calls the recorder with one message, the recorder takes the ones queued
behind it itself, up to a limit (so the flush and discovery timers and the other topics still get
their turn), through the subscription's own ``take_message`` (what the executors call; raw bytes
and message info). It stays on the SingleThreadedExecutor: the EventsExecutor fails on
message-info callbacks, which loss counting needs, and neither the MultiThreadedExecutor nor a
writer thread beats taking inline under the GIL. The rates are in ``docs/results/recorder.md``
(``track-bench recorder``).
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

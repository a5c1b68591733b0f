"""Taking every message a subscription holds in one callback: the recorder's batching.

rclpy's executors deliver one message per callback, and each delivery costs a pass of the
executor (wait set, ready list, task), many times what the rosbags ``Writer`` spends on a message.
So when the executor calls the recorder with one message, the recorder takes the ones queued
behind it itself, up to a limit (so the flush and discovery timers and the other topics still get
their turn), through the subscription's own ``take_message`` (what the executors call; raw bytes
and message info), in a loop that runs in C (``iter`` over the take, ``islice``). It stays on the
SingleThreadedExecutor: the EventsExecutor fails on message-info callbacks (rclpy 7.1: ``SystemError``),
and loss counting needs the sequence numbers; the MultiThreadedExecutor collapses under a burst; a
writer thread measured no faster (taking and packing both hold the GIL). The rates are in
``docs/results/recorder.md`` (``track-bench recorder``).
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import partial
from itertools import islice
from typing import Any


def can_take(sub: Any) -> bool:
    """True if ``sub`` has the handle method that ``take_pending`` relies on (rclpy 7.x)."""
    return callable(getattr(getattr(sub, 'handle', None), 'take_message', None))


def take_pending(sub: Any, limit: int) -> list[tuple[bytes, dict]]:
    """Up to ``limit`` (raw message, message info) pairs waiting in ``sub``; [] once it is destroyed."""
    from rclpy.exceptions import InvalidHandle

    try:
        handle = sub.handle
        with handle:  # the handle stays valid while we take (as in the executors)
            return list(islice(iter(partial(handle.take_message, sub.msg_type, True), None), limit))
    except InvalidHandle:
        return []


class BeforeClock:
    """Messages taken under ``use_sim_time`` before the first /clock (transient-local ones: /tf_static,
    a layout), held until the clock runs and written then with its first reading as their log time,
    not 0: a bag whose clock starts at an epoch must not begin in 1970. The caller holds its lock."""

    def __init__(self) -> None:
        self.held: list[tuple[Any, Sequence[bytes]]] = []  # (connection, CDR of one batch), in order

    def hold(self, conn: Any, raws: Sequence[bytes]) -> None:
        self.held.append((conn, raws))

    def release(self, write_many: Any, now: int) -> None:
        """``write_many(conn, stamps, raws)`` each held batch at ``now``."""
        for conn, raws in self.held:
            write_many(conn, [now] * len(raws), raws)
        self.held = []

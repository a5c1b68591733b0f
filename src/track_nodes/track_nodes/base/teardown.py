"""How a node process ends: its own cleanup in full, then the DDS entities' deletion under an alarm.

Fast DDS 2.14.5 (the only RMW on the package registries) can hang while it deletes entities when
many participants stop at once: ``destroy_participant`` spinning in ``DomainParticipant::set_listener``
while a peer-removal discovery callback waits for a lock, or ``destroy_publisher``/``_subscription``
/``_service`` blocking idle (cf. eProsima/Fast-DDS#6513 and #6502; seen at the stop of 25 processes
over 3 simulated hosts). The hang is in C with the GIL held, so no Python thread or
signal handler can act. A node process (``run_nodes``) therefore deletes its DDS entities under
``alarm(DDS_TEARDOWN_MAX)`` with SIGALRM's default action: if the deletion does not return, the
kernel ends the process (status -SIGALRM), and the launcher names it (``launch.processes``).

Nothing of ours is lost that way: a node's own cleanup (the recorder closing its bag) runs before
``rclpy.node.Node.destroy_node`` (subclasses clean up, then call ``super().destroy_node()``), and
the alarm covers only that call and the context's shutdown. What the peers miss is the participant's
goodbye: they drop it when its lease (20 s) runs out, as for an unplugged host.
"""

from __future__ import annotations

import contextlib
import signal
from collections.abc import Iterator
from types import SimpleNamespace

DDS_TEARDOWN_MAX = 5  # [wall s] for one node's entity deletion, or the context's shutdown
DDS_TEARDOWN_SIGNAL = signal.SIGALRM

# ``alarm``: set by run_nodes (a node process); in-process nodes (launcher, tests) are never cut off.
# ``done``: set once run_nodes has destroyed its nodes and shut rclpy down: what is left of the process
# is CPython's own finalization, which ``python -m track_nodes`` skips (track_nodes/__main__.py).
TEARDOWN = SimpleNamespace(done=False, alarm=False)


@contextlib.contextmanager
def dds_alarm() -> Iterator[None]:
    """Within a node process: end the process if the block (a DDS deletion) takes > DDS_TEARDOWN_MAX s."""
    armed = False
    if TEARDOWN.alarm:
        with contextlib.suppress(ValueError):  # not the main thread: no alarm
            # (the previous handler may be None: one installed outside Python, restored as SIG_DFL)
            previous = signal.signal(DDS_TEARDOWN_SIGNAL, signal.SIG_DFL)
            armed = True
    if not armed:
        yield
        return
    signal.alarm(DDS_TEARDOWN_MAX)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(DDS_TEARDOWN_SIGNAL, signal.SIG_DFL if previous is None else previous)

"""base/signals.py: SIGTERM/SIGHUP act as SIGINT; once teardown holds the stops, further ones are counted."""

from __future__ import annotations

import subprocess
import sys

import pytest

SCRIPT = '''
import signal
from track_nodes.base.signals import HELD, stop_on
signal.signal(signal.SIGINT, signal.default_int_handler)  # Python's default, also where SIGINT came ignored (a &)
if {stop_on}:
    stop_on(signal.SIGTERM, signal.SIGHUP)
try:
    signal.raise_signal(signal.SIGTERM if {stop_on} else signal.SIGINT)
except KeyboardInterrupt:
    print('stopping')
for sig in (signal.SIGINT, signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
    signal.raise_signal(sig)  # ros2 launch: its own SIGINT, SIGTERM 5 s later; a closed terminal
print('torn down', HELD.count)
'''


@pytest.mark.parametrize('stop_on', [True, False])
def test_stops_after_the_first_are_counted_not_raised(stop_on):
    """The first stop holds the later ones at once (no instant between them where a second Ctrl-C would cut
    teardown short); without stop_on, Python's default handler raises again."""
    proc = subprocess.run([sys.executable, '-c', SCRIPT.format(stop_on=stop_on)], capture_output=True, text=True,
                          timeout=120)
    if stop_on:
        assert proc.returncode == 0 and proc.stdout.split('\n')[:2] == ['stopping', 'torn down 4'], proc
    else:
        assert proc.returncode != 0 and 'KeyboardInterrupt' in proc.stderr and 'torn down' not in proc.stdout


# A node whose callback meets Ctrl-C inside C code: pybind11 turns the KeyboardInterrupt raised in a take's
# conversion into RuntimeError('Unable to convert call argument ...'); here a timer does the same by hand.
STOP_INSIDE_C = """
import signal, sys
from rclpy.node import Node
from track_nodes.base.run import run_nodes

class Taker(Node):
    def __init__(self):
        super().__init__('stop_inside_c')
        self.create_timer(0.05, self.take)

    def take(self):
        try:
            signal.raise_signal(signal.SIGINT)
        except KeyboardInterrupt:
            raise RuntimeError("Unable to convert call argument '0' to Python object") from None

sys.exit(run_nodes([('stop_inside_c', Taker)], ['prog'], program='stop_inside_c'))
"""


def test_a_stop_turned_into_another_error_inside_c_code_is_a_clean_stop(env_factory):
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, '-c', STOP_INSIDE_C], capture_output=True, text=True, timeout=120,
                          env=env_factory())
    assert proc.returncode == 0 and 'Traceback' not in proc.stderr, proc.stderr


NO_RCLPY_HANDLERS = """
import signal, sys
from rclpy.node import Node
from rclpy.signals import get_current_signal_handlers_options
from track_nodes.base.run import run_nodes

class Probe(Node):
    def __init__(self):
        super().__init__('probe')
        self.create_timer(0.05, self.probe)

    def probe(self):
        print('rclpy handlers:', get_current_signal_handlers_options().name, flush=True)
        signal.raise_signal(signal.SIGTERM)

sys.exit(run_nodes([('probe', Probe)], ['prog'], program='probe'))
"""


def test_a_node_process_leaves_the_stop_to_its_main_thread(env_factory):
    """rclpy's signal handlers are not installed: its signal thread shut the context down while the main
    thread built or destroyed the nodes (a SIGSEGV in about one stop in seven under load); the stop is
    the main thread's (base/signals.py), and SIGTERM still ends the process cleanly."""
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, '-c', NO_RCLPY_HANDLERS], capture_output=True, text=True, timeout=120,
                          env=env_factory())
    assert proc.returncode == 0 and 'rclpy handlers: NO' in proc.stdout, (proc.stdout, proc.stderr)

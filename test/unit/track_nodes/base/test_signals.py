"""base/signals.py: SIGTERM/SIGHUP act as SIGINT; once teardown holds the stops, further ones are counted."""

from __future__ import annotations

import subprocess
import sys

import pytest

SCRIPT = '''
import signal
from track_nodes.base.signals import HELD, stop_on
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

"""base/signals.py: SIGTERM/SIGHUP act as SIGINT; once teardown holds the stops, further ones are counted."""

from __future__ import annotations

import subprocess
import sys

import pytest

SCRIPT = '''
import signal
from track_nodes.base.signals import HELD, hold_stops, stop_on
stop_on(signal.SIGTERM, signal.SIGHUP)
try:
    signal.raise_signal(signal.SIGTERM)
except KeyboardInterrupt:
    print('stopping')
if {hold}:
    hold_stops()
for sig in (signal.SIGINT, signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
    signal.raise_signal(sig)
print('torn down', HELD.count)
'''


@pytest.mark.parametrize('hold', [True, False])
def test_stops_during_teardown_are_counted_not_raised(hold):
    proc = subprocess.run([sys.executable, '-c', SCRIPT.format(hold=hold)], capture_output=True, text=True,
                          timeout=120)
    if hold:
        assert proc.returncode == 0 and proc.stdout.split('\n')[:2] == ['stopping', 'torn down 4'], proc
    else:                                   # without: the second Ctrl-C cuts teardown short
        assert proc.returncode != 0 and 'KeyboardInterrupt' in proc.stderr and 'torn down' not in proc.stdout

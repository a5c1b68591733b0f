"""base/teardown.py: a DDS deletion that hangs ends a node process by SIGALRM; the launcher names it."""

from __future__ import annotations

import signal
import subprocess
import sys
from types import SimpleNamespace

import pytest

from track_nodes.launch.processes import failed_children

# Each case runs in its own interpreter: pytest's own timeout may hold the process's one alarm.
HANG = """
import time
from track_nodes.base import teardown
teardown.TEARDOWN.alarm = True
teardown.DDS_TEARDOWN_MAX = 1
with teardown.dds_alarm():
    print('in', flush=True)
    time.sleep({sleep})
print('out', flush=True)
"""

PLACES = """
import signal, threading
from track_nodes.base import teardown
teardown.DDS_TEARDOWN_MAX = 7
before = signal.getsignal(signal.SIGALRM)
with teardown.dds_alarm():  # no node process (TEARDOWN.alarm False): nothing armed
    print('off', signal.alarm(0), flush=True)
teardown.TEARDOWN.alarm = True
def worker():
    with teardown.dds_alarm():
        print('thread', signal.alarm(0), flush=True)
thread = threading.Thread(target=worker)
thread.start()
thread.join()
with teardown.dds_alarm():
    print('main', signal.getsignal(signal.SIGALRM) == signal.SIG_DFL, 0 < signal.alarm(0) <= 7, flush=True)
print('after', signal.alarm(0), signal.getsignal(signal.SIGALRM) == before, flush=True)
"""


def _run(script: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, '-c', script], capture_output=True, text=True, timeout=120)


def test_a_deletion_that_does_not_return_ends_the_process_by_sigalrm():
    done = _run(HANG.format(sleep=60))
    assert done.returncode == -signal.SIGALRM and done.stdout == 'in\n', (done.returncode, done.stderr)


def test_a_deletion_that_returns_goes_on():
    done = _run(HANG.format(sleep=0))
    assert done.returncode == 0 and done.stdout == 'in\nout\n', done.stderr


def test_armed_only_in_a_node_process_on_its_main_thread_then_disarmed():
    done = _run(PLACES)
    assert done.stdout.splitlines() == ['off 0', 'thread 0', 'main True True', 'after 0 True'], done.stderr


@pytest.mark.parametrize(('code', 'failed', 'says'), [
    (0, False, ''), (-signal.SIGINT, False, ''), (None, False, ''),
    (-signal.SIGALRM, False, 'its DDS teardown did not return within'),
    (2, True, 'exited with code 2'), (-signal.SIGKILL, True, 'exited with code -9'),
])
def test_failed_children_names_each_end(capsys, code, failed, says):
    child = SimpleNamespace(returncode=code, label='sensor_9', pid=1)
    assert (failed_children([child]) == [child]) is failed
    err = capsys.readouterr().err
    assert (says in err and 'sensor_9' in err) if says else err == ''

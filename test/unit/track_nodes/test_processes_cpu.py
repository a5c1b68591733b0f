"""``launch.processes.processes_cpu``: the CPU time of the children (every thread) and of the launcher."""

from __future__ import annotations

import subprocess
import sys
import time

from track_nodes.launch.processes import processes_cpu


def test_a_busy_child_counts_and_an_ended_one_does_not():
    busy = subprocess.Popen([sys.executable, '-c', 'import time\nt = time.process_time()\n'
                             'while time.process_time() - t < 0.5: pass\ninput()'], stdin=subprocess.PIPE)
    try:
        alone = processes_cpu([])
        while processes_cpu([busy]) - processes_cpu([]) < 0.4:  # its 0.5 s of CPU, however slowly it gets them
            assert busy.poll() is None
            time.sleep(0.05)
        assert processes_cpu([]) >= alone  # this process's own time only grows
    finally:
        busy.communicate(b'\n', timeout=60)
    assert processes_cpu([busy]) - processes_cpu([]) < 0.1  # ended: nothing of it counts

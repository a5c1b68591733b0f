"""A launcher run that an experiment script watches (tools/unplug_host.py, tools/handoff_figure.py).

Starts ``python -m track_nodes.launch ...`` with its output piped, reads stdout and stderr on two
threads (kept whole in ``out`` and ``err``) and notes what the experiments wait for: the simulated
hosts' tag and subnet (the launcher's ``hosts: N namespaces TAG-*, SUBNET,`` line) and the first IDSQ
leader (``started``, set by the sensor's "leading from a uniform belief" line).
"""

from __future__ import annotations

import re
import subprocess
import threading
from collections.abc import Sequence


class WatchedLaunch:
    def __init__(self, cmd: Sequence[str]) -> None:
        self.proc = subprocess.Popen(list(cmd), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        self.out: list[str] = []
        self.err: list[str] = []
        self.tag: str | None = None
        self.subnet: str | None = None
        self.hosts_known = threading.Event()
        self.started = threading.Event()
        self._threads = [threading.Thread(target=self._read, args=(self.proc.stdout, self.out), daemon=True),
                         threading.Thread(target=self._read, args=(self.proc.stderr, self.err), daemon=True)]
        for thread in self._threads:
            thread.start()

    def _read(self, stream, sink: list[str]) -> None:
        for line in stream:
            sink.append(line)
            if m := re.search(r'hosts: \d+ namespaces (\S+)-\*, (\S+),', line):
                self.tag, self.subnet = m.group(1), m.group(2)
                self.hosts_known.set()
            if 'leading from a uniform belief' in line:
                self.started.set()

    def wait(self) -> int:
        """The launcher's exit code, once its output is read to the end."""
        code = self.proc.wait()
        for thread in self._threads:
            thread.join()
        return code

    def stop(self) -> int:
        self.proc.terminate()
        return self.wait()

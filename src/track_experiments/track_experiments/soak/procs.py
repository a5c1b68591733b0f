"""Processes of a soak: started with their output in a log file, watched for a line, stopped by SIGTERM."""

from __future__ import annotations

import contextlib
import os
import re
import signal
import subprocess
import sys
import time
from collections.abc import Iterator, Sequence
from pathlib import Path

STOP_DEADLINE = 120.0  # [wall s] a process still running this long after SIGTERM is killed (and counted)

#: The recorder's last line: "recorded N messages (...) to PATH; lost 0" or "; LOST n (...)".
RECORDED = re.compile(r'recorded (\d+) messages .*?; (?:lost|LOST) (\d+)')


class Proc:
    """A child process whose stdout and stderr go to ``log`` (read back while it runs)."""

    def __init__(self, label: str, cmd: Sequence[str], log: Path, env: dict[str, str] | None = None,
                 cwd: Path | None = None) -> None:
        self.label, self.log = label, log
        self.t_start = time.monotonic()
        with open(log, 'wb') as out:
            self.popen = subprocess.Popen(list(cmd), stdout=out, stderr=subprocess.STDOUT, env=env, cwd=cwd,
                                          start_new_session=True)
        self.stop_s: float | None = None
        self.killed = False
        self._term_at: float | None = None

    def text(self) -> str:
        return self.log.read_text(errors='replace') if self.log.exists() else ''

    def wait_for(self, pattern: str, timeout: float) -> float | None:
        """Wall seconds from the start until ``pattern`` appears in the output; None if not in time or exited."""
        rx = re.compile(pattern)
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if rx.search(self.text()):
                return time.monotonic() - self.t_start
            if self.popen.poll() is not None:
                return None
            time.sleep(0.2)
        return None

    def send_term(self) -> None:
        """SIGTERM now (once); ``terminate`` then waits, timed from here."""
        if self._term_at is None:
            self._term_at = time.monotonic()
            if self.popen.poll() is None:
                with contextlib.suppress(ProcessLookupError):
                    self.popen.send_signal(signal.SIGTERM)

    def terminate(self, deadline: float = STOP_DEADLINE) -> int:
        """SIGTERM (unless sent), then wait; still running after ``deadline`` s: killed (``killed``)."""
        self.send_term()
        t0 = self._term_at
        try:
            self.popen.wait(timeout=deadline)
        except subprocess.TimeoutExpired:
            self.killed = True
            with contextlib.suppress(ProcessLookupError):
                os.killpg(self.popen.pid, signal.SIGKILL)
            self.popen.wait()
        self.stop_s = time.monotonic() - t0
        return self.popen.returncode

    def recorded(self) -> tuple[int, int] | None:
        """(messages recorded, messages lost) from the recorder's last line, if it printed one."""
        found = RECORDED.findall(self.text())
        return (int(found[-1][0]), int(found[-1][1])) if found else None

    def tail(self, n: int = 3) -> str:
        lines = [ln for ln in self.text().splitlines() if ln.strip()]
        return ' | '.join(lines[-n:])


def node_cmd(executable: str, *args: str) -> list[str]:
    """``python -m track_nodes EXECUTABLE ARGS`` with this interpreter (what the ros2-run shims run)."""
    return [sys.executable, '-m', 'track_nodes', executable, *args]


def launch_cmd(scenario: str, *args: str) -> list[str]:
    return [sys.executable, '-m', 'track_nodes.launch', scenario, *args]


@contextlib.contextmanager
def busy_loops(n: int) -> Iterator[None]:
    """``n`` CPU-bound processes for the duration of the block (a loaded machine)."""
    loops = [subprocess.Popen([sys.executable, '-c', 'while True: pass'], start_new_session=True)
             for _ in range(n)]
    try:
        yield
    finally:
        for p in loops:
            p.kill()
        for p in loops:
            p.wait()

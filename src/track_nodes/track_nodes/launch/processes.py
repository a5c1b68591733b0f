"""``--processes`` mode: one OS process per node, each in its own process group.

With ``hosts`` (``--hosts N``) node k runs in simulated host k mod N (``ip netns exec``); the
recorder stays in the launcher's namespace, which reaches every host, and discovers as a super
client of the launcher's discovery server (see ``hosts``).

A terminal Ctrl-C then reaches only the launcher, which stops the children (SIGINT, then a kill
of those that do not stop: ``stop_processes``) so the recorder closes its bag. A launcher that dies
without stopping them (SIGKILL) takes them along: each child asks the kernel for SIGINT at its
parent's death (``track_nodes.__main__.stop_with_parent``). A child that is
killed is asked for its Python stacks first (SIGUSR1), so a real hang says where.

A child that ends while the run goes on, for whatever reason (a crash, a SIGTERM sent to it alone,
which it takes as a clean stop, exit 0), stops the run: it is named in one line (name, how it
ended, pid) and the launcher exits non-zero (``ended_early``, ``failed_children``). Only a player
that has played its bag (exit 0) ends a run normally.
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from track_nodes.__main__ import PARENT_ENV
from track_nodes.base.teardown import DDS_TEARDOWN_MAX, DDS_TEARDOWN_SIGNAL
from track_nodes.launch.hosts import Hosts
from track_nodes.launch.scenario import NodeSpec
from track_nodes.launch.tuning import STOP_IDLE, STOP_MAX, STOP_WAIT


def spawn_nodes(specs: Sequence[NodeSpec], params_files: Sequence[str], sim: bool, bag: Path | None,
                record_regex: str, hosts: Hosts | None = None) -> list[subprocess.Popen]:
    """Start every node of ``specs`` (and the recorder when ``bag`` is set) as ``python -m track_nodes EXE``."""
    files = [a for f in params_files for a in ('--params-file', f)]
    use_sim = f'use_sim_time:={str(sim).lower()}'
    cmds = [[sys.executable, '-m', 'track_nodes', spec.executable, '--ros-args', '-r', f'__node:={spec.name}',
             *files, '-p', use_sim] for spec in specs]
    if bag is not None:
        cmds.append([sys.executable, '-m', 'track_nodes', 'recorder', '--ros-args', '-p', use_sim,
                     '-p', f'bag:={bag}', '-p', f'regex:={record_regex}', '-p', 'discard_empty:=true'])
    labels = [spec.name for spec in specs] + ['recorder']
    executables = [spec.executable for spec in specs] + ['recorder']
    children = []
    for k, cmd in enumerate(cmds):
        in_host = hosts is not None and k < len(specs)
        env = dict(os.environ) if hosts is None else hosts.env(super_client=not in_host)  # the recorder sees all
        env[PARENT_ENV] = str(os.getpid())  # the child stops when this launcher dies, even by SIGKILL
        child = subprocess.Popen([*hosts.prefix(k % hosts.n), *cmd] if in_host else cmd, env=env,
                                 start_new_session=True)
        child.label, child.executable = labels[k], executables[k]  # type: ignore[attr-defined]
        children.append(child)
    return children


def stop_processes(children: Sequence[subprocess.Popen]) -> None:
    """SIGINT every child still running; kill those that do not stop (see ``STOP_WAIT``).

    The stop is CPU work (destroy the nodes, close the bag, delete the DDS participant): on a loaded
    machine 25 processes doing it at once can take longer than ``STOP_WAIT`` of wall time, so a child
    whose main thread is still taking CPU time gets up to ``STOP_MAX``. A child that is killed is
    asked for its Python stacks first (SIGUSR1, faulthandler: see ``base/node.py``) and named.
    """
    for child in children:
        if child.poll() is None:
            child.send_signal(signal.SIGINT)
    t0 = time.monotonic()
    cpu: dict[int, float | None] = {}
    busy: dict[int, float] = {}  # pid -> last time its main thread was seen taking CPU
    while alive := [c for c in children if c.poll() is None]:
        now = time.monotonic()
        for child in alive:
            used = _main_thread_cpu(child.pid)
            if used is not None and used != cpu.get(child.pid):
                busy[child.pid] = now
            cpu[child.pid] = used
            elapsed, idle = now - t0, now - busy.get(child.pid, t0)
            if elapsed >= STOP_MAX or (elapsed >= STOP_WAIT and idle >= STOP_IDLE):
                why = f'working {elapsed:.0f} s' if idle < STOP_IDLE else f'idle for {idle:.0f} s'
                print(f'track_nodes.launch: {getattr(child, "label", child.pid)} still running {elapsed:.0f} s '
                      f'after SIGINT ({why}): its Python stacks follow (SIGUSR1), then killed',
                      file=sys.stderr, flush=True)
                with contextlib.suppress(ProcessLookupError):
                    child.send_signal(signal.SIGUSR1)  # faulthandler in base/node.py: every thread's stack
                with contextlib.suppress(subprocess.TimeoutExpired):
                    child.wait(timeout=1.0)
                child.kill()
                child.wait()
        time.sleep(0.1)


def processes_cpu(children: Sequence[subprocess.Popen]) -> float:
    """CPU time [s] used so far by the running ``children`` (every thread; Linux /proc) and this process.

    The launcher reads it when its clock starts and when it stops: the difference is the run's CPU
    for the clock's steps, bring-up and teardown excluded. A child that has already ended counts 0.
    """
    total = sum(os.times()[:2])
    tick = os.sysconf('SC_CLK_TCK')
    for child in children:
        try:
            with open(f'/proc/{child.pid}/stat') as f:
                fields = f.read().rsplit(')', 1)[1].split()
        except (OSError, IndexError):
            continue
        total += (float(fields[11]) + float(fields[12])) / tick  # utime, stime of every thread
    return total


def say_cpu(children: Sequence[subprocess.Popen], clock_cpu: tuple[float, float] | None) -> None:
    """The CPU time of the run's processes since ``clock_cpu`` = (monotonic s, ``processes_cpu``) at the
    clock's start, to the end of the drain (bring-up and teardown excluded), one line."""
    if clock_cpu is None or not children:
        return
    t0, cpu0 = clock_cpu
    print(f'cpu: {processes_cpu(children) - cpu0:.2f} s in {len(children)} processes and the launcher '
          f'from the clock\'s start to the end of the work ({time.monotonic() - t0:.1f} s wall)', flush=True)


def _main_thread_cpu(pid: int) -> float | None:
    """CPU time [clock ticks] of ``pid``'s main thread, None where /proc does not tell (or it is gone)."""
    try:
        with open(f'/proc/{pid}/task/{pid}/stat') as f:
            fields = f.read().rsplit(')', 1)[1].split()
    except (OSError, IndexError):
        return None
    return float(fields[11]) + float(fields[12])  # utime, stime (fields 14 and 15 of proc(5))


SELF_ENDING = ('player',)  # executables whose exit 0 while the run goes on is their end: the bag played


def exit_text(child: subprocess.Popen) -> str:
    """How ``child`` ended: 'exited with code C', with '(ended by SIGNAME)' when a signal ended it."""
    code = child.returncode
    if code is None or code >= 0:
        return f'exited with code {code}'
    try:
        return f'exited with code {code} (ended by {signal.Signals(-code).name})'
    except ValueError:
        return f'exited with code {code} (ended by signal {-code})'


def ended_early(children: Sequence[subprocess.Popen]) -> list[subprocess.Popen] | None:
    """While the run goes on: None as long as every child runs; else those that ended, a player that
    played its bag (exit 0, ``SELF_ENDING``) left out (the normal end of a replay)."""
    ended = [c for c in children if c.poll() is not None]
    if not ended:
        return None
    return [c for c in ended if not (c.returncode == 0 and getattr(c, 'executable', '') in SELF_ENDING)]


def failed_children(children: Sequence[subprocess.Popen],
                    early: Sequence[subprocess.Popen] = ()) -> list[subprocess.Popen]:
    """The children that failed, each named on stderr in one line: name, how it ended, pid.

    A child of ``early`` ended while the run went on (``ended_early``): whatever its exit code (a
    SIGTERM sent to it alone ends it cleanly, 0), the run lost a node, so it failed. After the run,
    a stop by SIGINT is clean; so is an end by the teardown alarm (-SIGALRM, base/teardown.py): the
    node had done its work and its own cleanup, and Fast DDS's entity deletion hung. That one is
    named too, as a warning, so that the hang is counted, not hidden.
    """
    failed = []
    for child in children:
        label = getattr(child, 'label', child.pid)
        if child in early:
            print(f'track_nodes.launch: {label} {exit_text(child)} while the run went on (pid {child.pid}): '
                  'the run stopped without it', file=sys.stderr)
            failed.append(child)
        elif child.returncode == -DDS_TEARDOWN_SIGNAL:
            print(f'track_nodes.launch: {label}: its DDS teardown did not return within {DDS_TEARDOWN_MAX} s '
                  '(a Fast DDS 2.14 deletion hang, see track_nodes.base.teardown); it ended itself',
                  file=sys.stderr)
        elif child.returncode not in (0, -signal.SIGINT, None):
            print(f'track_nodes.launch: {label} {exit_text(child)} (pid {child.pid})', file=sys.stderr)
            failed.append(child)
    return failed

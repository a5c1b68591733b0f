"""Stopping a launcher run: a ``--processes`` child that ends while the run goes on is named in one line and
fails the run; a second stop signal right after the first changes nothing (no traceback, the same status)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest


def launch(repo: Path, cwd: Path, env: dict, *extra: str) -> subprocess.Popen:
    cmd = [sys.executable, '-m', 'track_nodes.launch', str(repo / 'config/demo.yaml'), '--record', 'b',
           '--rate', '1', '--duration', '600', *extra]
    return subprocess.Popen(cmd, cwd=cwd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def children(pid: int) -> dict[int, str]:
    """pid → command line of the direct children of ``pid`` (Linux /proc)."""
    out = {}
    for task in Path(f'/proc/{pid}/task').iterdir():
        for child in (task / 'children').read_text().split():
            try:
                out[int(child)] = (Path('/proc') / child / 'cmdline').read_bytes().replace(b'\0', b' ').decode()
            except OSError:
                continue
    return out


def truth_flowing(ros, proc: subprocess.Popen) -> None:
    from nav_msgs.msg import Odometry
    from rclpy.node import Node

    from track_msgs_py.qos import ESTIMATE_QOS

    seen = []
    probe = ros.add(Node('stop_probe', context=ros.context))
    probe.create_subscription(Odometry, '/demo/truth', seen.append, ESTIMATE_QOS)
    assert ros.spin_until(lambda: len(seen) >= 3 or proc.poll() is not None, timeout=180), 'no truth'
    assert proc.poll() is None, proc.communicate()[1]


@pytest.mark.parametrize('sig', [signal.SIGTERM, signal.SIGKILL], ids=['SIGTERM', 'SIGKILL'])
def test_a_child_that_ends_during_the_run_is_named_and_fails_the_run(tmp_path, ros, repo, sig):
    proc = launch(repo, tmp_path, ros.env, '--processes')
    try:
        truth_flowing(ros, proc)
        tracker = next(pid for pid, cmd in children(proc.pid).items() if 'demo_tracker' in cmd)
        os.kill(tracker, sig)
        out, err = proc.communicate(timeout=180)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 2, err
    assert 'Traceback' not in err, err
    ours = [line for line in err.splitlines() if line.startswith('track_nodes.launch')]
    how = 'exited with code 0' if sig == signal.SIGTERM else 'ended by SIGKILL'
    assert len(ours) == 1, err
    assert 'demo_tracker' in ours[0] and how in ours[0] and f'pid {tracker}' in ours[0], ours
    assert (tmp_path / 'bags/b/metadata.yaml').is_file()  # the others stopped the usual way: the bag is closed
    assert 'position RMSE' in out  # the summary of what was recorded


@pytest.mark.parametrize('mode', [(), ('--processes',)], ids=['one-process', 'processes'])
def test_two_stop_signals_stop_like_one(tmp_path, ros, repo, mode):
    proc = launch(repo, tmp_path, ros.env, *mode)
    try:
        truth_flowing(ros, proc)
        proc.send_signal(signal.SIGTERM)
        ros.spin_for(0.2)  # the second signal 0.2 s after the first: while the first is being taken
        proc.send_signal(signal.SIGTERM)
        out, err = proc.communicate(timeout=180)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, err  # as one SIGTERM (test_launch_isolation)
    assert 'Traceback' not in err, err
    assert not [line for line in err.splitlines() if line.startswith('track_nodes.launch')], err
    assert (tmp_path / 'bags/b/metadata.yaml').is_file()
    assert 'position RMSE' in out

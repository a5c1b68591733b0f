"""How node processes stop: SIGUSR1 dumps a node's stacks without stopping it; after SIGINT it
tears down and leaves without CPython's module finalization, with exit code 0; the launcher kills only
children that do not work towards their exit; a domain Fast DDS cannot use is refused before it starts."""

from __future__ import annotations

import signal
import subprocess
import sys

import pytest
from nav_msgs.msg import Odometry
from rclpy.node import Node

from track_msgs_py.qos import ESTIMATE_QOS
from track_msgs_py.topics import DEMO_TRUTH

pytestmark = pytest.mark.integration


def test_sigusr1_dumps_stacks_and_sigint_stops_at_once(ros):
    probe = ros.add(Node('stop_probe', context=ros.context))
    truths: list = []
    probe.create_subscription(Odometry, DEMO_TRUTH, truths.append, ESTIMATE_QOS)
    proc = subprocess.Popen([sys.executable, '-m', 'track_nodes', 'demo_target', '--ros-args', '-r',
                             '__node:=stop_target'], env=ros.env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True)
    try:
        # its first truth proves the node spins (its name is in the graph already inside Node.__init__)
        assert ros.spin_until(lambda: len(truths) > 0, timeout=60), 'no truth from stop_target'
        proc.send_signal(signal.SIGUSR1)  # what the launcher sends to a child that does not stop
        assert ros.spin_until(lambda: proc.poll() is not None, timeout=1.0) is False, 'SIGUSR1 stopped the node'
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=30)
    finally:
        proc.kill()
    assert proc.returncode == 0, err
    assert 'most recent call first' in err and 'spin' in err, err  # every thread's stack, the executor's
    assert 'Traceback' not in err, err


def test_the_launcher_kills_an_idle_child_and_waits_for_a_working_one(monkeypatch, capfd):
    """stop_processes: after STOP_WAIT, a child whose main thread takes no CPU is killed (and named); one
    still working towards its exit is left to finish (a loaded machine), up to STOP_MAX."""
    from track_nodes.launch import processes

    monkeypatch.setattr(processes, 'STOP_WAIT', 1.0)
    monkeypatch.setattr(processes, 'STOP_IDLE', 0.5)
    ignore = 'import signal, time; signal.signal(signal.SIGINT, signal.SIG_IGN); print("up", flush=True); '
    dump = 'import faulthandler; faulthandler.register(signal.SIGUSR1, all_threads=True); '
    idle = subprocess.Popen([sys.executable, '-c', ignore + dump + 'time.sleep(60)'], stdout=subprocess.PIPE)
    spin = 't = time.monotonic()\nwhile time.monotonic() - t < 3: pass'
    busy = subprocess.Popen([sys.executable, '-c', ignore + spin], stdout=subprocess.PIPE)
    idle.label, busy.label = 'idle_child', 'busy_child'
    for child in (idle, busy):
        assert child.stdout.readline() == b'up\n'
    processes.stop_processes([idle, busy])
    assert idle.returncode == -signal.SIGKILL and busy.returncode == 0
    err = capfd.readouterr().err
    assert 'idle_child still running' in err and 'idle for' in err and 'busy_child' not in err, err
    assert 'most recent call first' in err, err  # the idle child's stack, before the kill


def test_a_domain_fast_dds_cannot_use_is_one_line_before_anything_starts(repo, tmp_path, env_factory):
    """Fast DDS exit(1)s in the first node's creation above domain 232 (no message of ours; with
    --hosts the namespaces were left behind): the launcher refuses it first, one line, exit 2."""
    env = {**env_factory(), 'ROS_DOMAIN_ID': '233'}
    proc = subprocess.run([sys.executable, '-m', 'track_nodes.launch', str(repo / 'config/idsq.yaml'), '--processes',
                           '--hosts', '1', '--duration', '1'], cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 2 and proc.stderr.strip().splitlines() == [
        'track_nodes.launch: ROS_DOMAIN_ID=233: Fast DDS needs 0..232 (its UDP ports)'], proc.stderr
    assert 'hosts:' not in proc.stdout


@pytest.mark.parametrize('gap', [0.0, 0.05, 0.3])
def test_the_signals_launch_sends_stop_a_node_cleanly(ros, gap):
    """``ros2 launch`` at Ctrl-C: the terminal's SIGINT and launch's own, then SIGTERM after a while. However
    close they come, teardown finishes: exit code 0 (launch reports no node "died"), no traceback."""
    probe = ros.add(Node('launch_stop_probe', context=ros.context))
    truths: list = []
    probe.create_subscription(Odometry, DEMO_TRUTH, truths.append, ESTIMATE_QOS)
    proc = subprocess.Popen([sys.executable, '-m', 'track_nodes', 'demo_target', '--ros-args', '-r',
                             '__node:=launch_stop_target'], env=ros.env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True)
    try:
        assert ros.spin_until(lambda: len(truths) > 0, timeout=60), 'no truth from launch_stop_target'
        for sig in (signal.SIGINT, signal.SIGINT, signal.SIGTERM):
            if proc.poll() is None:
                proc.send_signal(sig)
            ros.spin_until(lambda: proc.poll() is not None, timeout=gap) if gap else None
        _, err = proc.communicate(timeout=30)
    finally:
        proc.kill()
    assert proc.returncode == 0, err
    assert 'Traceback' not in err and 'KeyboardInterrupt' not in err, err

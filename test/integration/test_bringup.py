"""Bring-up: every node announces itself on /track/ready once built, the launcher waits for those
announcements (not for names in the graph), one node per name (in one process at once; of two
processes the newcomer refuses, exit 2), and Ctrl-C while many nodes are being built is a clean stop."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys

import pytest
from diagnostic_msgs.msg import DiagnosticStatus
from rclpy.node import Node

from track_msgs_py.records.ready import NodeReady
from track_msgs_py.topics import READY
from track_nodes.base import TrackNode
from track_nodes.base.ready import ALLOW_TWINS, WATCH_QOS
from track_nodes.idsq.scenario_files import idsq_yaml
from track_nodes.launch.graph import LauncherNode

pytestmark = pytest.mark.integration


class _Quiet(TrackNode):
    DEFAULT_NAME = 'quiet'


def _announcements(ros) -> list[NodeReady]:
    """Every announcement on /track/ready, as it arrives (transient-local: earlier ones too)."""
    heard: list[NodeReady] = []
    probe = ros.add(Node(f'ready_probe_{len(ros.nodes)}', context=ros.context))
    probe.create_subscription(DiagnosticStatus, READY, lambda m: heard.append(NodeReady.from_msg(m)), WATCH_QOS)
    return heard


def test_a_node_announces_itself_once_built(ros):
    ros.add(_Quiet(node_name='announcer', namespace='/robot1', context=ros.context))
    heard = _announcements(ros)  # subscribed after the node was built: the announcement is latched
    assert ros.spin_until(lambda: heard, timeout=30), 'no announcement on /track/ready'
    rec = heard[0]
    assert (rec.name, rec.pid, rec.host) == ('/robot1/announcer', os.getpid(), socket.gethostname())
    assert rec.start_ns > 0 and rec.executable


def test_the_launcher_waits_for_announcements_not_for_names_in_the_graph(ros):
    launcher = ros.add(LauncherNode(ros.context))
    ros.add(Node('silent', context=ros.context))  # in the graph, never announced: not a node that is up
    ros.add(_Quiet(node_name='loud', context=ros.context))
    assert ros.spin_until(lambda: not launcher.nodes_missing(['loud']), timeout=30)
    assert ros.spin_until(lambda: 'silent' in launcher.get_node_names(), timeout=30)
    assert launcher.nodes_missing(['silent', 'loud', '/loud']) == ['silent']


def test_a_second_node_of_one_name_in_one_process_is_refused_at_once(ros):
    first = _Quiet(node_name='twin', context=ros.context)
    with pytest.raises(ValueError, match=f'a node named /twin already runs in this process.*{ALLOW_TWINS}=1'):
        _Quiet(node_name='twin', context=ros.context)
    ros.add(_Quiet(node_name='twin', namespace='/other', context=ros.context))  # another name: fine
    first.destroy_node()
    ros.add(_Quiet(node_name='twin', context=ros.context))  # the name is free again


def _node(env, name: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, '-m', 'track_nodes', 'demo_target', '--ros-args', '-r', f'__node:={name}'],
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)


def test_of_two_processes_of_one_name_the_newcomer_refuses(ros):
    heard = _announcements(ros)
    older = _node(ros.env, 'twin_target')
    procs = [older]
    try:
        assert ros.spin_until(lambda: any(r.pid == older.pid for r in heard), timeout=90), 'the first never announced'
        newcomer = _node(ros.env, 'twin_target')
        procs.append(newcomer)
        _, err = newcomer.communicate(timeout=90)
        lines = err.strip().splitlines()
        assert newcomer.returncode == 2 and len(lines) == 1, err
        assert 'twin_target already runs' in lines[0] and f'pid {older.pid}' in lines[0] and ALLOW_TWINS in lines[0]
        assert older.poll() is None, 'the older node stopped too'
        allowed = _node({**ros.env, ALLOW_TWINS: '1'}, 'twin_target')  # asked for: both run
        procs.append(allowed)
        assert ros.spin_until(lambda: any(r.pid == allowed.pid for r in heard), timeout=90), 'the allowed twin'
        assert older.poll() is None and allowed.poll() is None
    finally:
        for proc in procs:
            if proc.poll() is None:
                proc.send_signal(signal.SIGINT)
        outs = [proc.communicate(timeout=60) for proc in procs]
    assert older.returncode == 0 and allowed.returncode == 0, outs
    assert {r.name for r in heard} == {'/twin_target'}


def test_ctrl_c_while_many_nodes_are_built_in_one_process_is_a_clean_stop(ros, tmp_path):
    """The launcher builds a 48-sensor field in its process; a Ctrl-C once the first node is built (the
    sensors still to come) is said in one line and stops it with exit 0 and no traceback."""
    scenario = tmp_path / 'field.yaml'
    scenario.write_text(idsq_yaml(n_sensors=48))
    proc = subprocess.Popen([sys.executable, '-m', 'track_nodes.launch', str(scenario), '--duration', '5'],
                            cwd=tmp_path, env=ros.env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        for line in proc.stderr:  # vehicle_sim, the first node, logs its layout once built
            if '[vehicle_sim]: 48 sensors' in line:
                proc.send_signal(signal.SIGINT)
                break
        out, err = proc.communicate(timeout=120)
    finally:
        proc.kill()
    assert proc.returncode == 0 and 'Traceback' not in err, err[-3000:]
    said = [ln for ln in err.splitlines() if 'Ctrl-C while building node' in ln]
    assert len(said) == 1 and 'of 49: stopping' in said[0], err[-3000:]
    assert '/clock from' not in out, out  # stopped before the clock started


def test_a_deadline_that_runs_out_names_what_is_missing_and_how_it_was_derived(ros, repo, monkeypatch):
    from rclpy.executors import MultiThreadedExecutor

    from track_nodes.launch import graph, launcher
    from track_nodes.launch.scenario import NodeSpec, Scenario

    monkeypatch.setattr(graph, 'READY_TIMEOUT', 0.5)
    monkeypatch.setattr(graph, 'READY_PER_NODE', 0.25)
    sc = Scenario('ghosts', repo / 'config/demo.yaml', [NodeSpec('demo_target', 'loud'),
                                                        NodeSpec('demo_target', 'ghost')], {})
    launch = launcher.Launch(sc, launcher._parse(['ghosts', '--rate', '0']))
    launch.context = ros.context
    node = ros.add(LauncherNode(ros.context))
    ros.add(_Quiet(node_name='loud', context=ros.context))
    executor = MultiThreadedExecutor(context=ros.context)
    executor.add_node(node)
    try:
        with pytest.raises(launcher.LaunchError) as exc:
            launch._wait_ready(node, executor, [])
    finally:
        executor.remove_node(node)
        executor.shutdown()
    assert str(exc.value) == ('not ready after 1 s (the deadline for 2: 0.5 s + 0.25 s per node in one process): '
                              'waiting for the announcement of ghost on /track/ready (1 of 2 nodes)')

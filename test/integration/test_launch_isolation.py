"""The launcher's operation: runs that never mix, a foreign /clock that stops a run, SIGTERM and
SIGHUP that stop like SIGINT, and a watchdog that stops a run whose clock no longer advances."""

from __future__ import annotations

import signal
import subprocess
import sys
from pathlib import Path

import pytest
from rosbags.rosbag2 import Reader

DEMO_ARGS = ('--duration', '4', '--rate', '20', '--epoch', '2026-01-01T00:00:00')


def payloads(bag: Path) -> dict[str, list[bytes]]:
    out: dict[str, list[bytes]] = {}
    with Reader(bag) as reader:
        for conn, _, raw in reader.messages():
            out.setdefault(conn.topic, []).append(bytes(raw))
    return out


def launcher(repo: Path, cwd: Path, env: dict, *extra: str, **kw) -> subprocess.Popen:
    cmd = [sys.executable, '-m', 'track_nodes.launch', str(repo / 'config/demo.yaml'), *extra]
    return subprocess.Popen(cmd, cwd=cwd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **kw)


def no_domain(env: dict) -> dict:
    """The environment of a user who set no ROS_DOMAIN_ID (the launcher picks one)."""
    return {k: v for k, v in env.items() if k != 'ROS_DOMAIN_ID'}


def test_two_concurrent_runs_record_what_each_records_alone(tmp_path, env_factory, repo):
    env = no_domain(env_factory())
    alone = launcher(repo, tmp_path, env, '--record', 'alone', *DEMO_ARGS)
    _, err = alone.communicate(timeout=180)
    assert alone.returncode == 0, err
    first = launcher(repo, tmp_path, env, '--record', 'first', *DEMO_ARGS)
    second = launcher(repo, tmp_path, env, '--record', 'second', *DEMO_ARGS)
    outs = [p.communicate(timeout=180) for p in (first, second)]
    assert first.returncode == 0 and second.returncode == 0, [e for _, e in outs]
    expected = payloads(tmp_path / 'bags/alone')
    assert {t: len(v) for t, v in expected.items()} == dict.fromkeys(('/demo/truth', '/demo/reports', '/demo/track'),
                                                                      40)
    for name in ('first', 'second'):
        got = payloads(tmp_path / 'bags' / name)
        assert got.keys() == expected.keys(), name
        for topic in expected:
            assert got[topic] == expected[topic], (name, topic, len(got[topic]))
    domains = [line for o, _ in outs for line in o.splitlines() if line.startswith('ROS_DOMAIN_ID=')]
    assert len(domains) == 2 and domains[0] != domains[1] and 'ros2 topic echo' in domains[0], domains


def test_a_foreign_clock_publisher_stops_the_run_with_one_line(tmp_path, ros, repo):
    from rclpy.node import Node
    from rosgraph_msgs.msg import Clock

    from track_msgs_py.qos import CLOCK_QOS

    node = ros.add(Node('other_clock', context=ros.context))
    node.create_publisher(Clock, '/clock', CLOCK_QOS)
    # The user set the domain on purpose (shared with this test's node): only the check can tell.
    proc = launcher(repo, tmp_path, ros.env, '--duration', '60', '--rate', '2')
    _, err = proc.communicate(timeout=180)
    assert proc.returncode == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and 'not alone' in lines[0] and '/clock' in lines[0] and 'other_clock' in lines[0], err


def test_a_failed_recorded_run_leaves_no_bag_directory(tmp_path, env_factory, repo):
    """A node process that fails at start (a bad value: its one line) stops the run before it started, after
    the recorder opened its bag: no empty bag directory is left behind (nor any bag of a run that never ran)."""
    bad = tmp_path / 'bad.yaml'
    bad.write_text('/**/demo_target:\n  ros__parameters:\n    period: -1.0\n')
    proc = launcher(repo, tmp_path, env_factory(), '--processes', '--params', str(bad), '--record', 'failed',
                    *DEMO_ARGS)
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 2 and 'demo_target exited with code 2 at start' in err, err
    assert 'period' in err, err  # the node's own line
    assert not (tmp_path / 'bags' / 'failed').exists(), sorted((tmp_path / 'bags').rglob('*'))


@pytest.mark.parametrize('sig', [signal.SIGTERM, signal.SIGHUP], ids=['SIGTERM', 'SIGHUP'])
def test_sigterm_and_sighup_stop_like_sigint(tmp_path, ros, repo, sig):
    from nav_msgs.msg import Odometry
    from rclpy.node import Node

    from track_msgs_py.qos import ESTIMATE_QOS

    seen = []
    probe = ros.add(Node('signal_probe', context=ros.context))
    probe.create_subscription(Odometry, '/demo/truth', seen.append, ESTIMATE_QOS)
    proc = launcher(repo, tmp_path, ros.env, '--record', 'b', '--rate', '1', '--duration', '600')
    try:
        assert ros.spin_until(lambda: len(seen) >= 3 or proc.poll() is not None, timeout=120), 'no truth'
        assert proc.poll() is None
        proc.send_signal(sig)
        out, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, err
    bag = tmp_path / 'bags/b'
    assert (bag / 'metadata.yaml').is_file()
    assert len(payloads(bag).get('/demo/truth', [])) >= 3
    assert 'position RMSE' in out  # the summary of a normal end


STUCK = '''
import sys, time
from track_nodes.base import TrackNode
from track_nodes.launch import launcher, scenario

class Stuck(TrackNode):
    """Test only: a node-time timer whose callback blocks from node time 1 s on (a TrackNode: it announces)."""
    def setup(self):
        self.t0 = None
        self.create_timer(0.5, self.tick)

    def tick(self):
        now = self.get_clock().now().nanoseconds * 1e-9
        self.t0 = now if self.t0 is None else self.t0
        if now - self.t0 >= 1.0:
            time.sleep(3600)

known = scenario.NodeSpec.node_class
scenario.NodeSpec.node_class = lambda self: Stuck if self.executable == 'stuck' else known(self)
raise SystemExit(launcher.main(sys.argv[1:]))
'''


def test_watchdog_names_the_callback_that_blocks_and_stops(tmp_path, env_factory, repo):
    (tmp_path / 'stuck.yaml').write_text('track_launch:\n  ros__parameters:\n    nodes: [demo_target, "stuck:stuck"]\n'
                                         '    record_regex: "^/demo/"\n'
                                         'demo_target:\n  ros__parameters:\n    seed: 7\n    period: 0.1\n')
    (tmp_path / 'stuck.py').write_text(STUCK)
    proc = subprocess.run([sys.executable, str(tmp_path / 'stuck.py'), str(tmp_path / 'stuck.yaml'), '--record', 's',
                           '--duration', '30', '--rate', '10', '--watchdog', '3'],
                          cwd=tmp_path, env=env_factory(), capture_output=True, text=True, timeout=180)
    assert proc.returncode == 1, proc.stderr
    ours = [line for line in proc.stderr.splitlines() if line.startswith('track_nodes.launch')]
    assert len(ours) == 1, proc.stderr
    assert 'has not advanced' in ours[0] and 'the timer of stuck' in ours[0] and 'has not returned' in ours[0], ours
    assert (tmp_path / 'bags/s/metadata.yaml').is_file()  # stopped the usual way: the bag is closed


SLOW = '''
import sys, time
from track_nodes.base import TrackNode
from track_nodes.launch import launcher, scenario

class Slow(TrackNode):
    """Test only: every callback takes 0.3 s of wall time and counts its start and its end on stderr."""
    def setup(self):
        self.create_timer(0.5, self.tick)

    def tick(self):
        print('tick start', file=sys.stderr, flush=True)
        time.sleep(0.3)
        print('tick end', file=sys.stderr, flush=True)

known = scenario.NodeSpec.node_class
scenario.NodeSpec.node_class = lambda self: Slow if self.executable == 'slow' else known(self)
raise SystemExit(launcher.main(sys.argv[1:]))
'''


def test_sigterm_while_the_clock_runs_lets_the_callback_finish_and_closes_the_bag(tmp_path, env_factory):
    """A stop signal during a run is taken between two callbacks: none is cut in the middle (every 'start'
    has its 'end'), the run ends the usual way (exit 0, the bag closed)."""
    (tmp_path / 'slow.yaml').write_text('track_launch:\n  ros__parameters:\n    nodes: [demo_target, "slow:slow"]\n'
                                        '    record_regex: "^/demo/"\n')
    (tmp_path / 'slow.py').write_text(SLOW)
    proc = subprocess.Popen([sys.executable, str(tmp_path / 'slow.py'), str(tmp_path / 'slow.yaml'), '--record', 's',
                             '--duration', '1000', '--rate', '10'], cwd=tmp_path, env=env_factory(),
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    lines: list[str] = []
    try:
        while sum(line.startswith('tick start') for line in lines) < 3:
            line = proc.stderr.readline()
            assert line, ''.join(lines)
            lines.append(line)
        proc.send_signal(signal.SIGTERM)   # most likely inside a 0.3 s callback
        lines += proc.communicate(timeout=120)[1].splitlines(keepends=True)
    finally:
        proc.kill()
    assert proc.returncode == 0, ''.join(lines)
    ticks = [line.split()[1] for line in lines if line.startswith('tick ')]
    assert ticks == ['start', 'end'] * (len(ticks) // 2), ticks
    assert 'Traceback' not in ''.join(lines), ''.join(lines)
    assert (tmp_path / 'bags/s/metadata.yaml').is_file()


def test_watchdog_deadline_grows_with_the_graph_and_the_steps():
    from track_nodes.launch.lockstep import Watchdog
    from track_nodes.launch.tuning import STALL_MIN

    small, big = Watchdog(2), Watchdog(200)
    assert small.deadline() == STALL_MIN and big.deadline() > STALL_MIN
    small.steps.extend([0.01, 5.0])
    assert small.deadline() > 5.0 * 10
    assert Watchdog(200, fixed=3.0).deadline() == 3.0


def test_no_domain_twice_on_one_machine():
    from track_nodes.launch.isolation import free_domain

    a, lock_a = free_domain()
    b, lock_b = free_domain()
    try:
        assert a != b
    finally:
        lock_a.close()
        lock_b.close()
    c, lock_c = free_domain()
    lock_c.close()
    assert c <= max(a, b)  # released ids are taken again


def test_a_range_is_searched_from_its_start_and_wraps_past_held_ids():
    """Test domains (test/conftest.py) come from a range and a start; held ids are skipped (240..: unused ids)."""
    from track_nodes.launch.isolation import free_domain

    held = [free_domain(240, 242, 242)]
    try:
        assert held[0][0] == 242
        held.append(free_domain(240, 242, 242))
        assert held[1][0] == 240  # wrapped past the held 242
        held.append(free_domain(240, 242, 242))
        assert held[2][0] == 241
        with pytest.raises(RuntimeError, match=r"240\.\.242"):
            free_domain(240, 242, 242)
    finally:
        for _, lock in held:
            lock.close()


def _marked(mark: str) -> list[int]:
    """Pids of the processes whose environment carries ``mark`` (the run's children, wherever they went)."""
    import os

    pids = []
    for entry in Path('/proc').iterdir():
        if entry.name.isdigit() and int(entry.name) != os.getpid():
            try:
                if mark.encode() in (entry / 'environ').read_bytes():
                    pids.append(int(entry.name))
            except OSError:
                continue
    return pids


def test_a_killed_processes_launcher_takes_its_nodes_along_and_the_bag_is_closed(tmp_path, ros, repo):
    """SIGKILL of a ``--processes`` launcher: every node gets SIGINT at its parent's death (PR_SET_PDEATHSIG),
    so none is left running and the recorder closes its bag (metadata.yaml written)."""
    import contextlib
    import os
    import uuid

    from nav_msgs.msg import Odometry
    from rclpy.node import Node

    from track_msgs_py.qos import ESTIMATE_QOS

    token = uuid.uuid4().hex
    mark = f'TRACK_TEST_RUN={token}'
    env = {**ros.env, 'TRACK_TEST_RUN': token}
    seen = []
    probe = ros.add(Node('kill_probe', context=ros.context))
    probe.create_subscription(Odometry, '/demo/truth', seen.append, ESTIMATE_QOS)
    proc = launcher(repo, tmp_path, env, '--processes', '--record', 'k', '--rate', '1', '--duration', '600')
    try:
        assert ros.spin_until(lambda: len(seen) >= 3 or proc.poll() is not None, timeout=180), 'no truth'
        children = [p for p in _marked(mark) if p != proc.pid]
        assert len(children) >= 3, children  # demo_target, demo_tracker, the recorder
        proc.kill()
        proc.communicate(timeout=30)
        assert ros.spin_until(lambda: not [p for p in _marked(mark) if p in children], timeout=60), \
            [p for p in _marked(mark) if p in children]
    finally:
        for p in _marked(mark):
            with contextlib.suppress(OSError):
                os.kill(p, signal.SIGKILL)
    assert (tmp_path / 'bags/k/metadata.yaml').is_file()
    assert len(payloads(tmp_path / 'bags/k').get('/demo/truth', [])) >= 3

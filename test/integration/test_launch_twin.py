"""A second launcher on a domain that a run already uses is refused before it publishes anything
(``track_nodes.launch.twin``), and the first run completes untouched."""

from __future__ import annotations

import subprocess
import sys
from collections import Counter
from pathlib import Path

from rosbags.rosbag2 import Reader


def launch(repo: Path, cwd: Path, env: dict, name: str, *extra: str) -> subprocess.Popen:
    cmd = [sys.executable, '-m', 'track_nodes.launch', str(repo / 'config/demo.yaml'), *extra]
    out, err = open(cwd / f'{name}.out', 'w'), open(cwd / f'{name}.err', 'w')  # noqa: SIM115 (the run's life)
    return subprocess.Popen(cmd, cwd=cwd, env=env, stdout=out, stderr=err, text=True)


def counts(bag: Path) -> dict[str, int]:
    with Reader(bag) as reader:
        return dict(Counter(conn.topic for conn, _, _ in reader.messages()))


def test_a_second_launcher_on_the_domain_is_refused_before_it_publishes(tmp_path, ros, repo):
    from rclpy.node import Node

    watch = ros.add(Node('twin_watch', context=ros.context))  # no publisher on the run's topics
    run = ('--duration', '60', '--rate', '2', '--epoch', '2026-01-01T00:00:00')
    first = launch(repo, tmp_path, ros.env, 'first', '--record', 'first', *run)
    second = None
    try:
        started = lambda: '/clock from' in (tmp_path / 'first.out').read_text()  # noqa: E731
        assert ros.spin_until(lambda: started() or first.poll() is not None, timeout=180), 'the first never started'
        assert first.poll() is None, (tmp_path / 'first.err').read_text()
        second = launch(repo, tmp_path, ros.env, 'second', '--record', 'second', *run)
        most: Counter = Counter()

        def second_done() -> bool:
            for topic in ('/clock', '/demo/truth', '/demo/reports'):
                most[topic] = max(most[topic], watch.count_publishers(topic))
            return second.poll() is not None

        assert ros.spin_until(second_done, timeout=180), 'the second launcher never ended'
        first_running = first.poll() is None
        first.wait(timeout=300)
    finally:
        for proc in (first, second):
            if proc is not None and proc.poll() is None:
                proc.kill()
                proc.wait()
    err2 = (tmp_path / 'second.err').read_text()
    assert second.returncode == 2, err2
    lines = err2.strip().splitlines()
    assert len(lines) == 1 and 'not alone' in lines[0] and 'nothing published' in lines[0], err2
    assert most == {'/clock': 1, '/demo/truth': 1, '/demo/reports': 1}, most  # the second published nothing
    assert not (tmp_path / 'bags/second').exists()
    err1 = (tmp_path / 'first.err').read_text()
    assert first_running, 'the first run ended while the second was refused'
    assert first.returncode == 0, err1
    assert 'went backwards' not in err1 and 'not alone' not in err1, err1
    assert counts(tmp_path / 'bags/first') == {'/demo/truth': 600, '/demo/reports': 600, '/demo/track': 600}
    hint = next(line for line in (tmp_path / 'first.out').read_text().splitlines() if line.startswith('ROS_DOMAIN_ID='))
    assert 'ros2 topic' in hint and 'foxglove' in hint and 'export' not in hint, hint

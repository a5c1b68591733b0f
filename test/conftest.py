"""Test harness shared by unit and integration tests.

Install prefix: tests find our packages the way ``ros2 run`` does, through the ament index on
``AMENT_PREFIX_PATH`` (``make`` sets it to ``.venv``; ``colcon test`` to the workspace's
``install/`` prefixes; unset, it defaults to the venv). ``prefix`` is where track_nodes is
installed (``lib/track_nodes/<shim>``, ``bin/track-*``), ``venv`` the running interpreter's prefix.

ROS isolation: every test that touches ROS gets its own ``rclpy.Context`` on a unique
``ROS_DOMAIN_ID`` with discovery restricted to localhost, so tests never see each other's
(or anybody else's) topics. Subprocesses started by a test get the same domain through
``ros.env``.
"""

from __future__ import annotations

import collections
import itertools
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest

# Localhost-only discovery for everything started from the tests (Jazzy's replacement of
# ROS_LOCALHOST_ONLY). Set before any context is initialised.
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ.pop('ROS_LOCALHOST_ONLY', None)

REPO = Path(__file__).resolve().parents[1]
VENV = Path(sys.prefix)
os.environ.setdefault('AMENT_PREFIX_PATH', str(VENV))
_domains = itertools.count()
_held: collections.deque = collections.deque()  # locks on the ids handed out last
HELD = 8  # a test uses a domain for a while after it was handed out: its lock is kept for 8 more


def _next_domain_id() -> int:
    # 1..100; under pytest-xdist each worker has its own slice (2 workers: 1..50 and 51..100), so a
    # suite's workers never collide. Another suite on this machine (or a launcher's test run) holds
    # locks on the ids it uses (the launcher's lock files): those are skipped (launch.isolation.free_domain).
    from track_nodes.launch.isolation import free_domain

    workers = int(os.environ.get('PYTEST_XDIST_WORKER_COUNT', '1'))
    worker = os.environ.get('PYTEST_XDIST_WORKER', 'gw0')
    size = 100 // max(1, min(workers, 100))
    k = int(worker[2:]) if worker[2:].isdigit() else 0
    first = 1 + k * size
    start = first + (os.getpid() + next(_domains)) % size
    try:
        domain, lock = free_domain(first, first + size - 1, start)
    except RuntimeError:  # every id of the slice held: share one, as before
        return start
    _held.append(lock)
    while len(_held) > HELD:
        _held.popleft().close()
    return domain


def spin_until(executor, predicate: Callable[[], bool], timeout: float = 10.0, step: float = 0.05) -> bool:
    """Spin ``executor`` until ``predicate()`` is true or ``timeout`` seconds pass; return the predicate."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        executor.spin_once(timeout_sec=step)
    return bool(predicate())


class RosHarness:
    """An isolated ROS context, an in-process executor and helpers for one test."""

    def __init__(self) -> None:
        import rclpy
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor

        self.domain_id = _next_domain_id()
        self.context = Context()
        rclpy.init(context=self.context, domain_id=self.domain_id)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.nodes: list = []
        self.env = {**os.environ, 'ROS_DOMAIN_ID': str(self.domain_id), 'PYTHONUNBUFFERED': '1'}

    def add(self, node):
        """Register ``node`` with the executor; it is destroyed at teardown."""
        self.nodes.append(node)
        self.executor.add_node(node)
        return node

    def spin_until(self, predicate: Callable[[], bool], timeout: float = 10.0) -> bool:
        return spin_until(self.executor, predicate, timeout)

    def spin_for(self, seconds: float) -> None:
        spin_until(self.executor, lambda: False, seconds)

    def close(self) -> None:
        for node in self.nodes:
            self.executor.remove_node(node)
            node.destroy_node()
        self.executor.shutdown()
        self.context.try_shutdown()


@pytest.fixture
def ros():
    harness = RosHarness()
    try:
        yield harness
    finally:
        harness.close()


@pytest.fixture(scope='session')
def repo() -> Path:
    return REPO


@pytest.fixture(scope='session')
def venv() -> Path:
    return VENV


def package_prefix(pkg: str) -> Path:
    """The install prefix of ``pkg`` in the ament index, as ``ros2 run`` finds it."""
    from ament_index_python.packages import get_package_prefix

    return Path(get_package_prefix(pkg))


@pytest.fixture(scope='session')
def prefix() -> Path:
    """Where track_nodes is installed: ``lib/track_nodes/<executable>``, ``bin/track-*``, ``share/track_nodes``."""
    return package_prefix('track_nodes')


def isolated_env() -> dict[str, str]:
    """Environment for a subprocess on a fresh ROS domain (localhost-only discovery)."""
    return {**os.environ, 'ROS_DOMAIN_ID': str(_next_domain_id()), 'PYTHONUNBUFFERED': '1'}


@pytest.fixture(scope='session')
def env_factory():
    """Call it for a fresh isolated subprocess environment; usable from module-scoped fixtures."""
    return isolated_env


def flip_chunk_bit(mcap: Path, which: int = 1) -> int:
    """Flip one bit of the ``which``-th chunk of ``mcap`` (its last byte: a message payload's, so the file still
    parses and only the chunk's CRC can tell); → the chunk's byte offset."""
    import struct

    data = bytearray(mcap.read_bytes())
    pos, seen = 8, 0
    while pos + 9 <= len(data):
        op, length = struct.unpack_from('<BQ', data, pos)
        seen += op == 0x06
        if op == 0x06 and seen == which:
            data[pos + 9 + length - 1] ^= 0x10
            mcap.write_bytes(bytes(data))
            return pos
        pos += 9 + length
    raise ValueError(f'{mcap}: no chunk {which}')


@pytest.fixture(scope='session')
def flip_bit():
    """``flip_chunk_bit``: a bag damaged the way a bad disk or cable damages it."""
    return flip_chunk_bit

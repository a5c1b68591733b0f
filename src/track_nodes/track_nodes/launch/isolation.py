"""Isolation of a launcher run: its own DDS domain, localhost-only discovery, no foreign publishers.

Two runs on one machine share nothing by default:

- **Discovery on localhost only** (``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``, for the launcher
  and every child): a run never reaches another machine, and nobody on the network receives its
  ``/clock``. ``--network`` keeps the discovery range of the environment (Jazzy's default: the
  subnet), for runs that are meant to be watched from elsewhere. ``--hosts`` sets its own
  (a discovery server on the bridge, see ``hosts``).
- **A domain of its own** when the user set no ``ROS_DOMAIN_ID``: the lowest id of
  ``DOMAIN_FIRST..MAX_DOMAIN_ID`` that no other launcher on this machine holds (an advisory lock
  on a file per id, released by the kernel when the process ends, however it ends). Localhost
  discovery alone does not separate two runs on one machine; a domain does, and costs nothing.
  The id is printed with how to watch the run (``ros2 topic``, ``track-foxglove``): watching, not a
  second launch, which ``twin.probe`` refuses. An id the user set is used as it is.
- **A check for foreign publishers** (``LauncherNode.foreign``) while the run goes: a second
  ``/clock`` publisher, or more publishers on one of the run's topics than the run's own nodes
  have, stops the run with one line. It catches what the two rules above cannot: a shared id set
  on purpose, a player left running, another program on the same domain.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import tempfile
import time
from collections import Counter
from pathlib import Path

from track_nodes.launch.tuning import DOMAIN_FIRST, FOREIGN_EVERY, MAX_DOMAIN_ID

LOCK_DIR = Path(tempfile.gettempdir()) / 'track_nodes-launch-domains'


class Isolation:
    """The environment of one run; hold it for the run's life (``with Isolation(...) as iso``)."""

    def __init__(self, network: bool) -> None:
        self.network = network
        self.domain: int | None = None
        self.chosen = False  # True: the domain was picked here (not set by the user)
        self._lock = None

    def acquire(self) -> Isolation:
        """Set this process's environment (inherited by the children); raises RuntimeError when no id is free."""
        if not self.network:
            os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
            os.environ.pop('ROS_LOCALHOST_ONLY', None)
        given = os.environ.get('ROS_DOMAIN_ID', '').strip()
        if given:
            self.domain = int(given)
            return self
        self.domain, self._lock = free_domain()
        self.chosen = True
        os.environ['ROS_DOMAIN_ID'] = str(self.domain)
        return self

    def __enter__(self) -> Isolation:
        return self

    def __exit__(self, *_exc) -> None:
        if self._lock is not None:
            self._lock.close()
            self._lock = None

    def describe(self) -> str:
        reach = 'the network' if self.network else 'localhost only'
        own = 'a domain of its own; ' if self.chosen else ''
        d = self.domain
        return (f'ROS_DOMAIN_ID={d} ({own}discovery: {reach}; watch it with ROS_DOMAIN_ID={d} ros2 topic echo TOPIC '
                f'or ROS_DOMAIN_ID={d} track-foxglove; a second launch on it is refused)')


def free_domain(first: int = DOMAIN_FIRST, last: int = MAX_DOMAIN_ID, start: int | None = None) -> tuple[int, object]:
    """The first id of ``first..last`` (from ``start``, wrapping) no other process here holds, and its held lock.

    The launcher takes the lowest free id of its range; the tests (``test/conftest.py``) take theirs
    from 1..100 the same way, so suites running side by side never share a domain.
    """
    LOCK_DIR.mkdir(mode=0o1777, parents=True, exist_ok=True)
    ids = list(range(first, last + 1))
    if start is not None and first <= start <= last:
        ids = ids[start - first:] + ids[:start - first]
    for domain in ids:
        try:
            fd = os.open(LOCK_DIR / f'{domain}.lock', os.O_RDWR | os.O_CREAT, 0o666)
        except OSError:  # another user's file: taken
            continue
        lock = os.fdopen(fd, 'w')
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            lock.close()
            continue
        with contextlib.suppress(OSError):
            lock.write(f'{os.getpid()}\n')
            lock.flush()
        return domain, lock
    raise RuntimeError(f'every ROS domain id {first}..{last} is held by another run on this machine; '
                       'set ROS_DOMAIN_ID to share one')


class ForeignCheck:
    """Looks, every ``FOREIGN_EVERY`` wall seconds, for what in the run's domain is not the run's.

    ``nodes``: the run's in-process nodes (their publishers are counted per topic), or None when
    they live in other processes (then the /clock publishers and the node names are checked).
    A finding counts when two looks in a row agree, so a publisher that is just going away
    (the graph lags) stops nothing.
    """

    def __init__(self, launcher, names: list[str], nodes: list | None, sim: bool) -> None:
        self.launcher, self.names, self.nodes, self.sim = launcher, names, nodes, sim
        self.next = time.monotonic()
        self.suspect: str | None = None

    def look(self) -> str | None:
        """None, or the one line that stops the run."""
        if time.monotonic() < self.next:
            return None
        self.next = time.monotonic() + FOREIGN_EVERY
        own = None if self.nodes is None else dict(Counter(
            pub.topic_name for node in self.nodes for pub in node.publishers))
        found = self.launcher.foreign(self.names, own, self.sim)
        confirmed, self.suspect = found is not None and self.suspect is not None, found
        if not confirmed:
            return None
        domain = os.environ.get('ROS_DOMAIN_ID') or '0'
        return f'not alone in ROS_DOMAIN_ID={domain}: {found}; stopped (another run or program shares this domain)'

"""Simulated hosts on one machine: Linux network namespaces on a bridge (``--hosts N``).

Layout (checked on this kind of machine, as root): a hub namespace holds a
bridge (``mcast_snooping 0``); host ``i`` is a namespace with one veth into that bridge, address
``.i+1`` of a /24 that is unique per run. The launcher's own namespace (normally the root one) gets
one more veth into the bridge, address ``.254``: the launcher (/clock, graph watching) and the
recorder stay where they are and see every host over one hop, as the hosts see each other.

Names and subnet are unique per run (pid plus a random byte); everything is removed on leaving the
context, at exit and on SIGTERM/SIGHUP. Discovery is real Fast DDS: unicast to the static peers
(every host and the launcher) with ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``.
"""

from __future__ import annotations

import atexit
import contextlib
import ipaddress
import itertools
import os
import secrets
import shutil
import signal
import subprocess
import time
from collections.abc import Sequence

LAUNCHER_HOST = 254  # last octet of the launcher's own address on the bridge


def unavailable() -> str | None:
    """None when this machine can create network namespaces here, else the reason (one line)."""
    if not hasattr(os, 'geteuid') or os.geteuid() != 0:
        return 'simulated hosts need root (ip netns add)'
    if shutil.which('ip') is None:
        return 'simulated hosts need the ip command (iproute2)'
    probe = f'tp{os.getpid() % 100000}{secrets.token_hex(2)}'
    res = subprocess.run(['ip', 'netns', 'add', probe], capture_output=True, text=True)
    if res.returncode != 0:
        return f'ip netns add failed: {res.stderr.strip() or res.returncode}'
    subprocess.run(['ip', 'netns', 'del', probe], capture_output=True)
    return None


def _free_subnet(seed: int) -> ipaddress.IPv4Network:
    """A 10.x.y.0/24 derived from ``seed`` that overlaps no route of this namespace."""
    routes = subprocess.run(['ip', '-4', 'route', 'show', 'table', 'all'], capture_output=True,
                            text=True).stdout.split()
    taken = []
    for word in routes:
        with contextlib.suppress(ValueError):
            taken.append(ipaddress.ip_network(word, strict=False))
    for k in range(1000):
        n = (seed + 7919 * k) % (100 * 256)
        net = ipaddress.ip_network(f'10.{100 + n // 256}.{n % 256}.0/24')
        if not any(net.overlaps(t) for t in taken if t.prefixlen > 0):
            return net
    raise RuntimeError('no free 10.x.y.0/24 subnet for simulated hosts')


_RUNS = itertools.count()  # a process's runs get distinct tags; the pid and a random byte separate processes


class Hosts:
    """``n`` simulated hosts; use as a context manager (``with Hosts(3) as hosts: ...``)."""

    def __init__(self, n: int, tag: str | None = None) -> None:
        if n < 1:
            raise ValueError(f'need at least one host, got {n}')
        self.n = n
        self.tag = tag or f't{os.getpid() % 100000}{next(_RUNS) % 16:x}{secrets.token_hex(1)}'
        self.subnet = _free_subnet(os.getpid() * 256 + secrets.randbelow(256))
        self.names = [f'{self.tag}-h{i}' for i in range(n)]
        self.hub = f'{self.tag}-hub'
        self.root_veth = f'{self.tag}r'
        self.addresses = [str(self.subnet[i + 1]) for i in range(n)]
        self.launcher_address = str(self.subnet[LAUNCHER_HOST])
        self.setup_s = 0.0
        self._up = False
        self._old_handlers: dict[int, object] = {}

    # -- environment and commands for a process in host i --------------------------------
    @property
    def static_peers(self) -> str:
        return ';'.join([*self.addresses, self.launcher_address])

    def env(self, base: dict[str, str] | None = None) -> dict[str, str]:
        """The environment of any participant of the run: unicast discovery to every host.

        The domain id is the caller's (``ROS_DOMAIN_ID`` of ``base``): one per concurrent run.
        """
        env = dict(os.environ if base is None else base)
        env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
        env['ROS_STATIC_PEERS'] = self.static_peers
        env.pop('ROS_LOCALHOST_ONLY', None)
        return env

    def prefix(self, i: int) -> list[str]:
        """Command prefix that runs a program in host ``i``."""
        return ['ip', 'netns', 'exec', self.names[i]]

    # -- setup and teardown ---------------------------------------------------------------
    def __enter__(self) -> Hosts:
        atexit.register(self.remove)
        for sig in (signal.SIGTERM, signal.SIGHUP):
            if signal.getsignal(sig) is signal.SIG_DFL:
                self._old_handlers[sig] = signal.signal(sig, _raise_exit)
        t0 = time.monotonic()
        self._up = True
        try:
            self._create()
        except BaseException:
            self.remove()
            raise
        self.setup_s = time.monotonic() - t0
        return self

    def __exit__(self, *_exc) -> None:
        self.remove()

    def _create(self) -> None:
        plen = self.subnet.prefixlen
        cmds = [['netns', 'add', self.hub], ['-n', self.hub, 'link', 'set', 'lo', 'up'],
                ['-n', self.hub, 'link', 'add', 'br0', 'type', 'bridge', 'mcast_snooping', '0'],
                ['-n', self.hub, 'link', 'set', 'br0', 'up']]
        for i, name in enumerate(self.names):
            veth, peer = f'{self.tag}h{i}', f'{self.tag}b{i}'
            cmds += [['netns', 'add', name], ['-n', name, 'link', 'set', 'lo', 'up'],
                     ['link', 'add', veth, 'netns', name, 'type', 'veth', 'peer', 'name', peer, 'netns', self.hub],
                     ['-n', self.hub, 'link', 'set', peer, 'master', 'br0', 'up'],
                     ['-n', name, 'addr', 'add', f'{self.addresses[i]}/{plen}', 'dev', veth],
                     ['-n', name, 'link', 'set', veth, 'up']]
        cmds += [['link', 'add', self.root_veth, 'type', 'veth', 'peer', 'name', f'{self.tag}rb', 'netns', self.hub],
                 ['-n', self.hub, 'link', 'set', f'{self.tag}rb', 'master', 'br0', 'up'],
                 ['addr', 'add', f'{self.launcher_address}/{plen}', 'dev', self.root_veth],
                 ['link', 'set', self.root_veth, 'up']]
        for cmd in cmds:
            res = subprocess.run(['ip', *cmd], capture_output=True, text=True)
            if res.returncode != 0:
                raise RuntimeError(f'ip {" ".join(cmd)}: {res.stderr.strip()}')

    def remove(self) -> None:
        """Delete every namespace and device of this run (idempotent; never raises)."""
        if not self._up:
            return
        self._up = False
        subprocess.run(['ip', 'link', 'del', self.root_veth], capture_output=True)
        for name in [*self.names, self.hub]:
            subprocess.run(['ip', 'netns', 'del', name], capture_output=True)
        for sig, old in self._old_handlers.items():
            if signal.getsignal(sig) is _raise_exit:
                signal.signal(sig, old)
        self._old_handlers.clear()
        atexit.unregister(self.remove)

    def leftovers(self) -> list[str]:
        """Namespaces of this run that still exist (for tests: empty after ``remove``)."""
        listed = subprocess.run(['ip', 'netns', 'list'], capture_output=True, text=True).stdout.split()
        return [n for n in [*self.names, self.hub] if n in listed]

    def set_link(self, i: int, up: bool) -> None:
        """Plug (``up``) or unplug host ``i``: its port on the bridge goes up or down."""
        subprocess.run(['ip', '-n', self.hub, 'link', 'set', f'{self.tag}b{i}', 'up' if up else 'down'],
                       check=True, capture_output=True)


def _raise_exit(signum: int, _frame) -> None:
    raise SystemExit(128 + signum)


def round_robin(items: Sequence, n: int) -> list[int]:
    """The host of each item: 0, 1, ..., n-1, 0, 1, ..."""
    return [k % n for k in range(len(items))]

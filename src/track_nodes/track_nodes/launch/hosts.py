"""Simulated hosts on one machine: Linux network namespaces on a bridge (``--hosts N``).

Layout (checked on this kind of machine, as root): a hub namespace holds a
bridge (``mcast_snooping 0``); host ``i`` is a namespace with one veth into that bridge, address
``.i+1`` of a /24 that is unique per run. The launcher's own namespace (normally the root one) gets
one more veth into the bridge, address ``.254``: the launcher (/clock, graph watching) and the
recorder stay where they are and see every host over one hop, as the hosts see each other.

Names and subnet are unique per run (pid plus a random byte); everything is removed on leaving the
context, at exit and on SIGTERM/SIGHUP.

Discovery is real Fast DDS, through a discovery server: the launcher's own participant is the
SERVER (``server_env``), every node is a CLIENT of it (``ROS_DISCOVERY_SERVER``) and the recorder a
SUPER_CLIENT (it must see every topic to record by regex); the two in the launcher's namespace get
XML profiles pinned to the bridge address (``participant_profile``). With simple discovery every
participant announces every endpoint to every other one, so each process's discovery work grows as
N² with the field (100 sensors over 10 hosts did not come up in 8 min on 2 cores, the sensors busy
in Fast DDS's event threads); a client is told only of the endpoints on its own topics, and needs
only the server's address. Transport is UDPv4 only (``FASTDDS_BUILTIN_TRANSPORTS``): ``ip netns
exec`` shares ``/dev/shm``, and the shared-memory ports, which Fast DDS derives from a participant
id picked per network stack, collided across hosts (``RTPS_TRANSPORT_SHM Error ...
open_and_lock_file failed`` at 100 sensors over 10 hosts).

A new veth gets its carrier after a delay, and a participant created before lists no address on
it: a participant pinned to it fails ("All whitelist interfaces were filtered out", checked on a
veth without carrier), and an unpinned one would announce no locator there (our reading of runs in
which discovery worked but no node's /track/ready reached the launcher). Entering the context waits
for every carrier (``LINK_UP_MAX``).
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
import tempfile
import time
from pathlib import Path

from track_nodes.launch.tuning import LINK_UP_MAX

LAUNCHER_HOST = 254  # last octet of the launcher's own address on the bridge
DISCOVERY_PORT = 11811  # the discovery server's UDP port on the launcher's address (Fast DDS's default)
SERVER_PREFIX = '44.53.00.5f.45.50.52.4f.53.49.4d.41'  # what a ROS_DISCOVERY_SERVER client expects of server 0


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
        self._server_dir: tempfile.TemporaryDirectory | None = None  # the launcher's and recorder's profiles
        self._old_handlers: dict[int, object] = {}

    # -- environment and commands for a process in host i --------------------------------
    @property
    def static_peers(self) -> str:
        return ';'.join([*self.addresses, self.launcher_address])

    @property
    def discovery_server(self) -> str:
        return f'{self.launcher_address}:{DISCOVERY_PORT}'

    def env(self, base: dict[str, str] | None = None, *, super_client: bool = False) -> dict[str, str]:
        """The environment of a node of the run: a client of the launcher's discovery server, UDPv4 only.

        ``super_client``: for a participant in the launcher's namespace that must be told of every
        endpoint (the recorder records by regex). The domain id is the caller's (``ROS_DOMAIN_ID`` of
        ``base``): one per concurrent run. The static peers stay for a participant that ignores the
        server variable.
        """
        env = dict(os.environ if base is None else base)
        if self._server_dir is not None and env.get('FASTRTPS_DEFAULT_PROFILES_FILE', '').startswith(
                self._server_dir.name):
            env.pop('FASTRTPS_DEFAULT_PROFILES_FILE')  # the launcher's own profile is not its children's
        env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
        env['ROS_STATIC_PEERS'] = self.static_peers
        env['ROS_DISCOVERY_SERVER'] = self.discovery_server
        env['FASTDDS_BUILTIN_TRANSPORTS'] = 'UDPv4'
        env.pop('ROS_LOCALHOST_ONLY', None)
        env.pop('ROS_SUPER_CLIENT', None)
        return self._on_bridge(env, 'SUPER_CLIENT') if super_client else env

    def server_env(self, base: dict[str, str] | None = None) -> dict[str, str]:
        """The environment of the launcher's process: its participant is the run's discovery server.

        A participant with a SERVER profile is also told of every endpoint, which the launcher's graph
        watching needs.
        """
        return self._on_bridge(self.env(base), 'SERVER')

    def _on_bridge(self, env: dict[str, str], role: str) -> dict[str, str]:
        """``env`` for a participant of the launcher's namespace: an XML profile (``participant_profile``,
        a temporary file removed with the hosts) that pins it to the bridge address, instead of the
        discovery variables.

        The launcher's namespace has more interfaces than a host (the machine's own, other runs'
        bridges); pinned, its participants announce only the address every host reaches. rmw_fastrtps's
        LOCALHOST range makes a participant with a listening locator on the bridge fail to be created;
        with a discovery server nothing is multicast.
        """
        path = Path(self._profile_dir()) / f'{role.lower()}.xml'
        if not path.exists():
            path.write_text(participant_profile(role, self.launcher_address, DISCOVERY_PORT))
        env['FASTRTPS_DEFAULT_PROFILES_FILE'] = str(path)
        env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'SUBNET'
        for key in ('ROS_DISCOVERY_SERVER', 'ROS_STATIC_PEERS'):
            env.pop(key, None)
        return env

    def _profile_dir(self) -> str:
        if self._server_dir is None:
            self._server_dir = tempfile.TemporaryDirectory(prefix=f'{self.tag}-dds-')
        return self._server_dir.name

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
        self._wait_running()

    def _wait_running(self, timeout: float = LINK_UP_MAX) -> None:
        """Until every veth of the run reports its carrier (``LOWER_UP``): the kernel signals a new
        carrier with a delay of up to a second, and a participant created before lists no address on
        that interface (seen: the launcher's profile, pinned to its address, then failed with "All
        whitelist interfaces were filtered out")."""
        links = [([], self.root_veth)] + [(['-n', name], f'{self.tag}h{i}') for i, name in enumerate(self.names)]
        deadline = time.monotonic() + timeout
        while links:
            links = [(ns, dev) for ns, dev in links if 'LOWER_UP' not in subprocess.run(
                ['ip', *ns, '-o', 'link', 'show', dev], capture_output=True, text=True).stdout]
            if links and time.monotonic() > deadline:
                raise RuntimeError(f'simulated hosts: no carrier on {", ".join(dev for _, dev in links)} after '
                                   f'{timeout:g} s')
            if links:
                time.sleep(0.02)

    def remove(self) -> None:
        """Delete every namespace and device of this run, and the server's profile (idempotent; never raises)."""
        if self._server_dir is not None:
            self._server_dir.cleanup()
            self._server_dir = None
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


def remove_leftovers(tag: str) -> list[str]:
    """Belt and braces after a launcher that did not exit cleanly (killed): kill what still runs in the
    namespaces of run ``tag`` (by pid) and delete them; the names that were left."""
    listed = subprocess.run(['ip', 'netns', 'list'], capture_output=True, text=True).stdout.split()
    left = [n for n in listed if n.startswith(f'{tag}-')]
    for name in left:
        pids = subprocess.run(['ip', 'netns', 'pids', name], capture_output=True, text=True).stdout.split()
        for pid in pids:
            with contextlib.suppress(ProcessLookupError, ValueError):
                os.kill(int(pid), signal.SIGKILL)
        subprocess.run(['ip', 'netns', 'del', name], capture_output=True)
    if left:
        subprocess.run(['ip', 'link', 'del', f'{tag}r'], capture_output=True)
    return left


def participant_profile(role: str, address: str, port: int) -> str:
    """A Fast DDS 2.14 XML profile: the default participant is discovery server 0 on ``address:port``
    (``role`` SERVER; its GUID prefix is the one ``ROS_DISCOVERY_SERVER`` clients expect at position 0)
    or a SUPER_CLIENT of it; UDPv4 only, on the interface of ``address`` only."""
    if role == 'SERVER':
        discovery = f'''<discoveryProtocol>SERVER</discoveryProtocol>
          </discovery_config>
          <metatrafficUnicastLocatorList>
            <locator><udpv4><address>{address}</address><port>{port}</port></udpv4></locator>
          </metatrafficUnicastLocatorList>'''
        prefix = f'<prefix>{SERVER_PREFIX}</prefix>'
    elif role == 'SUPER_CLIENT':
        discovery = f'''<discoveryProtocol>SUPER_CLIENT</discoveryProtocol>
            <discoveryServersList>
              <RemoteServer prefix="{SERVER_PREFIX}">
                <metatrafficUnicastLocatorList>
                  <locator><udpv4><address>{address}</address><port>{port}</port></udpv4></locator>
                </metatrafficUnicastLocatorList>
              </RemoteServer>
            </discoveryServersList>
          </discovery_config>'''
        prefix = ''
    else:
        raise ValueError(f'role {role!r}: allowed SERVER, SUPER_CLIENT')
    return f'''<?xml version="1.0" encoding="UTF-8" ?>
<dds xmlns="http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles">
  <profiles>
    <transport_descriptors>
      <transport_descriptor>
        <transport_id>udp</transport_id><type>UDPv4</type>
        <interfaceWhiteList><address>{address}</address></interfaceWhiteList>
      </transport_descriptor>
    </transport_descriptors>
    <participant profile_name="track_nodes_{role.lower()}" is_default_profile="true">
      <rtps>
        {prefix}
        <useBuiltinTransports>false</useBuiltinTransports>
        <userTransports><transport_id>udp</transport_id></userTransports>
        <builtin>
          <discovery_config>
            {discovery}
        </builtin>
      </rtps>
    </participant>
  </profiles>
</dds>
'''


def _raise_exit(signum: int, _frame) -> None:
    raise SystemExit(128 + signum)

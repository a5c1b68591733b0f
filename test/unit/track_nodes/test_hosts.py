"""Simulated hosts (``track_nodes.launch.hosts``): names, subnet and env; create and always remove; unplug one.

The namespace tests need root and ``ip netns``; they skip with the reason otherwise.
"""

from __future__ import annotations

import ipaddress
import subprocess
from pathlib import Path
from xml.etree import ElementTree

import pytest

from track_nodes.launch.hosts import (
    DISCOVERY_PORT,
    SERVER_PREFIX,
    Hosts,
    participant_profile,
    remove_leftovers,
    unavailable,
)

REASON = unavailable()
needs_netns = pytest.mark.skipif(REASON is not None, reason=f'no simulated hosts here: {REASON}')


def test_unavailable_is_none_or_a_reason():
    assert REASON is None or (isinstance(REASON, str) and REASON)


def test_names_subnet_and_env_are_per_run():
    a, b = Hosts(3), Hosts(3)
    assert a.tag != b.tag and not set(a.names) & set(b.names)
    assert a.subnet.prefixlen == 24 and a.subnet.subnet_of(ipaddress.ip_network('10.0.0.0/8'))
    assert all(len(f'{a.tag}rb') <= 15 for _ in a.names)  # Linux device names: at most 15 characters
    env = a.env({'ROS_DOMAIN_ID': '42', 'ROS_LOCALHOST_ONLY': '1'})
    assert env['ROS_DOMAIN_ID'] == '42' and 'ROS_LOCALHOST_ONLY' not in env
    assert env['ROS_AUTOMATIC_DISCOVERY_RANGE'] == 'LOCALHOST'
    assert env['ROS_STATIC_PEERS'].split(';') == [*a.addresses, a.launcher_address]
    assert a.prefix(2) == ['ip', 'netns', 'exec', a.names[2]]


def _profile(env: dict[str, str]) -> dict[str, str]:
    """Tag -> text of the XML profile ``env`` names (attributes as '@name')."""
    root = ElementTree.parse(env['FASTRTPS_DEFAULT_PROFILES_FILE']).getroot()
    out = {}
    for el in root.iter():
        tag = el.tag.split('}')[1]
        out[tag] = (el.text or '').strip()
        out.update({f'@{k}': v for k, v in el.attrib.items()})
    return out


def test_nodes_are_clients_of_the_launchers_discovery_server_over_udp_only():
    a = Hosts(3)
    env = a.env({'ROS_DOMAIN_ID': '42', 'ROS_SUPER_CLIENT': 'TRUE'})
    assert env['ROS_DISCOVERY_SERVER'] == f'{a.launcher_address}:{DISCOVERY_PORT}'
    assert env['FASTDDS_BUILTIN_TRANSPORTS'] == 'UDPv4'  # the hosts share /dev/shm: no shared-memory ports
    assert 'ROS_SUPER_CLIENT' not in env and 'FASTRTPS_DEFAULT_PROFILES_FILE' not in env
    try:
        server = a.server_env({'ROS_DOMAIN_ID': '42'})
        recorder = a.env({'ROS_DOMAIN_ID': '42'}, super_client=True)
        for e in (server, recorder):  # the launcher's namespace: XML profiles pinned to the bridge address
            assert 'ROS_DISCOVERY_SERVER' not in e and 'ROS_STATIC_PEERS' not in e
            assert e['ROS_AUTOMATIC_DISCOVERY_RANGE'] == 'SUBNET' and e['ROS_DOMAIN_ID'] == '42'
            xml = _profile(e)
            assert xml['interfaceWhiteList'] == '' and xml['address'] == a.launcher_address
            assert xml['port'] == str(DISCOVERY_PORT) and xml['useBuiltinTransports'] == 'false'
        assert _profile(server)['discoveryProtocol'] == 'SERVER' and _profile(server)['prefix'] == SERVER_PREFIX
        assert _profile(recorder)['discoveryProtocol'] == 'SUPER_CLIENT'
        assert _profile(recorder)['@prefix'] == SERVER_PREFIX  # the server it asks
        # a child started from the launcher's environment is a client again, not a second server
        assert 'FASTRTPS_DEFAULT_PROFILES_FILE' not in a.env(server)
        files = [Path(e['FASTRTPS_DEFAULT_PROFILES_FILE']) for e in (server, recorder)]
        assert all(f.exists() for f in files)
    finally:
        a.remove()
    assert not any(f.exists() for f in files)  # removed with the hosts
    with pytest.raises(ValueError, match='role'):
        participant_profile('CLIENT', '10.0.0.1', 1)


@needs_netns
def test_hosts_get_their_addresses_and_are_removed():
    with Hosts(3) as hosts:
        assert hosts.setup_s < 10
        assert sorted(hosts.leftovers()) == sorted([*hosts.names, hosts.hub])
        # every link has its carrier when the context is entered: a participant made now sees its address
        assert 'LOWER_UP' in subprocess.run(['ip', '-o', 'link', 'show', hosts.root_veth], capture_output=True,
                                            text=True).stdout
        for i in range(3):
            out = subprocess.run([*hosts.prefix(i), 'ip', '-4', 'addr'], capture_output=True, text=True).stdout
            assert f'{hosts.addresses[i]}/24' in out and 'inet 127.0.0.1' in out
    assert hosts.leftovers() == []
    assert hosts.root_veth not in subprocess.run(['ip', 'link'], capture_output=True, text=True).stdout


@needs_netns
def test_hosts_are_removed_when_the_body_raises():
    with pytest.raises(RuntimeError), Hosts(2) as hosts:
        raise RuntimeError('boom')
    assert hosts.leftovers() == []


def test_not_root_is_a_reason(monkeypatch):
    monkeypatch.setattr('os.geteuid', lambda: 1000)
    assert unavailable() == 'simulated hosts need root (ip netns add)'


@needs_netns
def test_leftovers_of_a_killed_run_are_removed_by_tag():
    hosts = Hosts(2)
    hosts.__enter__()
    hosts._up = False  # as if its launcher was killed: nobody removes them ...
    try:
        assert sorted(remove_leftovers(hosts.tag)) == sorted([*hosts.names, hosts.hub])  # ... but this
        assert hosts.leftovers() == [] and remove_leftovers(hosts.tag) == []
        assert hosts.root_veth not in subprocess.run(['ip', 'link'], capture_output=True, text=True).stdout
    finally:
        hosts._up = True
        hosts.remove()


def _port_up(hosts: Hosts, i: int) -> bool:
    """Whether host ``i``'s port on the bridge is administratively up (``UP`` among its flags)."""
    out = subprocess.run(['ip', '-n', hosts.hub, '-o', 'link', 'show', f'{hosts.tag}b{i}'], capture_output=True,
                         text=True, check=True).stdout
    return 'UP' in out.split('<', 1)[1].split('>', 1)[0].split(',')


@needs_netns
def test_a_host_is_unplugged_and_plugged_again():
    with Hosts(2) as hosts:
        assert _port_up(hosts, 1)
        hosts.set_link(1, up=False)
        assert not _port_up(hosts, 1) and _port_up(hosts, 0)  # only that host's port
        hosts.set_link(1, up=True)
        assert _port_up(hosts, 1)

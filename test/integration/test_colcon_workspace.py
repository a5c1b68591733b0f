"""A colcon workspace works like our venv (issue 19 items 11-12).

The three packages are built with colcon into a scratch workspace (a copy of the checkout: ``src/``,
``test/``, the pytest and colcon configuration). A node starts from ``install/`` the way ``ros2 run``
finds it: ``install/setup.sh`` sourced, ``ament_index_python.get_package_prefix`` +
``lib/track_nodes/<executable>``, the interpreter being python3 on PATH (an activated venv).
``colcon test`` runs our packages' parts of the suite against ``install/`` and fails on a failing
test (a scratch one injected into the copy).
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
import rclpy
from nav_msgs.msg import Odometry

from track_msgs_py.qos import ESTIMATE_QOS
from track_msgs_py.topics import DEMO_TRUTH

pytestmark = pytest.mark.integration

# What a clone has that the tests read (config is a link into src/track_nodes).
COPIED = ('src', 'test', 'config', 'pyproject.toml', 'colcon_defaults.yaml', 'README.md', 'MAINTAINERS', 'LICENSE')
IGNORED = shutil.ignore_patterns('build', 'install', 'log', '*.egg-info', '__pycache__')
# The shim before issue 19 item 11: the venv's interpreter only (exit 127 in a colcon install/).
VENV_ONLY_SHIM = '#!/bin/sh\nexec "$(dirname "$0")/../../bin/python3" -m track_nodes demo_target "$@"\n'
# What `ros2 run track_nodes EXE ARGS` does: the package prefix from the ament index, then lib/<pkg>/<exe>.
ROS2_RUN = ('import os, sys\n'
            'from ament_index_python.packages import get_package_prefix\n'
            'exe = os.path.join(get_package_prefix("track_nodes"), "lib", "track_nodes", sys.argv[1])\n'
            'print(exe, flush=True)\n'
            'os.execv(exe, [exe, *sys.argv[2:]])\n')


def colcon(ws: Path, *args: str, env: dict[str, str], timeout: float = 120) -> subprocess.CompletedProcess:
    """``colcon ARGS`` in ``ws`` with this interpreter's colcon, no user defaults (COLCON_HOME in ``ws``)."""
    exe = Path(sys.executable).parent / 'colcon'
    cmd = [str(exe) if exe.is_file() else 'colcon', *args]
    return subprocess.run(cmd, cwd=ws, env=env, capture_output=True, text=True, timeout=timeout)


def ws_env(ws: Path, base: dict[str, str] | None = None) -> dict[str, str]:
    env = {**(base or os.environ), 'COLCON_HOME': str(ws / '.colcon'),
           'PATH': f'{Path(sys.executable).parent}{os.pathsep}{os.environ["PATH"]}'}
    env.pop('COLCON_DEFAULTS_FILE', None)
    return env


def build_workspace(repo: Path, ws: Path, *build_args: str) -> Path:
    for name in COPIED:
        src = repo / name
        if src.is_symlink():
            (ws / name).symlink_to(os.readlink(src))
        elif src.is_dir():
            shutil.copytree(src, ws / name, ignore=IGNORED)
        else:
            shutil.copy2(src, ws / name)
    proc = colcon(ws, 'build', *build_args, env=ws_env(ws))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return ws


@pytest.fixture(scope='module')
def workspace(repo, tmp_path_factory) -> Path:
    return build_workspace(repo, tmp_path_factory.mktemp('colcon_ws'))


@pytest.fixture(scope='module')
def symlink_workspace(repo, tmp_path_factory) -> Path:
    return build_workspace(repo, tmp_path_factory.mktemp('colcon_ws_symlink'), '--symlink-install')


def sourced(ws: Path, *cmd: str) -> list[str]:
    """``cmd`` run by sh after ``. install/setup.sh`` (what a user's shell does)."""
    return ['sh', '-c', '. "$0/install/setup.sh" && exec "$@"', str(ws), *cmd]


def test_a_node_runs_from_install_as_ros2_run_finds_it(workspace, ros):
    env = ws_env(workspace, ros.env)
    where = subprocess.run(sourced(workspace, 'python3', '-c', 'import track_nodes; print(track_nodes.__file__)'),
                           env=env, capture_output=True, text=True, timeout=60)
    assert where.returncode == 0 and where.stdout.startswith(str(workspace)), where.stdout + where.stderr
    assert not (workspace / 'install/track_nodes/bin/python3').exists()  # python3 comes from PATH

    probe = ros.add(rclpy.create_node('colcon_probe', context=ros.context))
    truths: list = []
    probe.create_subscription(Odometry, DEMO_TRUTH, truths.append, ESTIMATE_QOS)
    proc = subprocess.Popen(sourced(workspace, 'python3', '-c', ROS2_RUN, 'demo_target'), env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        up = ros.spin_until(lambda: len(truths) > 0, 60.0)  # spinning, not only named in the graph
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=30)
    finally:
        proc.kill()
    assert out.splitlines()[0] == str(workspace / 'install/track_nodes/lib/track_nodes/demo_target'), out + err
    assert up, f'no truth from demo_target over DDS: {out}{err}'
    assert proc.returncode == 0, err
    assert 'Traceback' not in err


def test_a_symlink_install_shim_runs(symlink_workspace, tmp_path):
    """--symlink-install: lib/track_nodes/<exe> is a link into build/; the shim still finds its interpreter."""
    ws = symlink_workspace
    shim = ws / 'install/track_nodes/lib/track_nodes/bag_recover'
    assert shim.is_symlink()
    proc = subprocess.run(sourced(ws, 'python3', '-c', ROS2_RUN, 'bag_recover', str(tmp_path / 'nope')),
                          env=ws_env(ws), capture_output=True, text=True, timeout=60)
    assert proc.stdout.splitlines() == [str(shim)], proc.stdout + proc.stderr
    assert proc.returncode == 2 and proc.stderr.strip().splitlines() == [
        f'track-bag-recover: {tmp_path / "nope"}: no such file or directory'], proc.stderr


def junit(ws: Path, pkg: str) -> dict[str, str]:
    """``test name -> passed|failed|skipped`` from colcon's pytest.xml of ``pkg``."""
    results = {}
    for case in ET.parse(ws / 'build' / pkg / 'pytest.xml').getroot().iter('testcase'):
        outcome = 'passed'
        for child in case:
            if child.tag in ('failure', 'error'):
                outcome = 'failed'
            elif child.tag == 'skipped':
                outcome = 'skipped'
        results[case.get('name')] = outcome
    return results


def test_colcon_test_runs_our_tests_and_fails_on_a_failing_one(workspace):
    """One cheap `colcon test`: -k picks a real test of track_core, a scratch failing one injected into the
    copy, and track_nodes' shim tests, which then run against install/ (the prefix the ament index gives)."""
    (workspace / 'test/unit/track_core/test_injected_failure.py').write_text(
        'def test_injected_failure():\n    assert 1 + 1 == 3\n')
    env = ws_env(workspace)
    selected = ' or '.join(('test_injected_failure', 'test_wrap_half_open_interval',
                            'test_shim_runs_a_node_with_bad_params_file_message',
                            'test_a_shim_in_a_prefix_without_python_runs_the_node'))
    proc = colcon(workspace, 'test', '--packages-select', 'track_core', 'track_nodes', '--pytest-args', '-k', selected,
                  env=env)
    assert proc.returncode != 0, proc.stdout  # colcon_defaults.yaml: return-code-on-test-failure
    assert 'track_core' in proc.stdout and 'test failures' in proc.stdout, proc.stdout

    core = junit(workspace, 'track_core')
    assert core.pop('test_injected_failure') == 'failed'
    assert core and set(core.values()) == {'passed'}, core
    nodes = junit(workspace, 'track_nodes')
    assert nodes == {'test_shim_runs_a_node_with_bad_params_file_message': 'passed',
                     'test_a_shim_in_a_prefix_without_python_runs_the_node': 'passed'}, nodes
    result = colcon(workspace, 'test-result', env=env)
    assert result.returncode != 0 and '1 failure' in result.stdout, result.stdout

    # The same track_nodes test against the old, venv-only shim: colcon test catches the exit 127.
    installed = workspace / 'install/track_nodes/lib/track_nodes/demo_target'
    installed.unlink()
    installed.write_text(VENV_ONLY_SHIM)
    installed.chmod(0o755)
    proc = colcon(workspace, 'test', '--packages-select', 'track_nodes', '--pytest-args',
                  '../../test/unit/track_nodes/test_install_layout.py', '-k',
                  'test_shim_runs_a_node_with_bad_params_file_message', env=env)
    assert proc.returncode != 0, proc.stdout
    assert junit(workspace, 'track_nodes') == {'test_shim_runs_a_node_with_bad_params_file_message': 'failed'}

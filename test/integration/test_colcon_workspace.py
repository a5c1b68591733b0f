"""A colcon workspace works like our venv: the README's steps, as written, on a fresh clone.

``README.md``, section "colcon workspace": its ``sh`` block is read from the README and run line by
line by ``sh`` in a fresh clone (every file git tracks, with the working tree's content; a copy of the
checkout where there is no git), in the environment of a new shell (no ``AMENT_PREFIX_PATH``, no
venv on ``PATH``). One line is not run as written: ``make install``, which would build a second venv
of minutes; ``.venv`` is linked to the venv this suite runs in, which ``make install`` made. The
workspace those steps built (the interface packages included) is then checked: a node starts from
``install/`` the way ``ros2 run`` finds it (``install/setup.sh`` sourced,
``ament_index_python.get_package_prefix`` + ``lib/track_nodes/<executable>``, the interpreter being
python3 on PATH), and ``colcon test`` runs our packages' parts of the suite against ``install/`` and
fails on a failing test (a scratch one injected into the clone).
"""

from __future__ import annotations

import os
import re
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

pytestmark = [pytest.mark.integration, pytest.mark.timeout(1800)]  # builds a workspace with its interfaces: minutes

# What a clone has that the tests read, where the checkout is no git repository (config links into src/track_nodes).
COPIED = ('src', 'interfaces', 'test', 'config', 'pyproject.toml', 'colcon_defaults.yaml', 'README.md', 'MAINTAINERS',
          'LICENSE', 'Makefile')
IGNORED = shutil.ignore_patterns('build', 'install', 'log', '*.egg-info', '__pycache__')
MAKE_INSTALL = 'make install'
# The shim before issue 19 item 11: the venv's interpreter only (exit 127 in a colcon install/).
VENV_ONLY_SHIM = '#!/bin/sh\nexec "$(dirname "$0")/../../bin/python3" -m track_nodes demo_target "$@"\n'
# What `ros2 run track_nodes EXE ARGS` does: the package prefix from the ament index, then lib/<pkg>/<exe>.
ROS2_RUN = ('import os, sys\n'
            'from ament_index_python.packages import get_package_prefix\n'
            'exe = os.path.join(get_package_prefix("track_nodes"), "lib", "track_nodes", sys.argv[1])\n'
            'print(exe, flush=True)\n'
            'os.execv(exe, [exe, *sys.argv[2:]])\n')


def readme_steps(readme: Path) -> list[str]:
    """The commands of the README's colcon ``sh`` block, one per line, comments removed."""
    section = readme.read_text().split('\n## colcon workspace', 1)[1].split('\n## ', 1)[0]
    block = section.split('```sh\n', 1)[1].split('```', 1)[0]
    return [re.sub(r'\s+#.*$', '', line).strip() for line in block.splitlines() if line.strip()]


def fresh_clone(repo: Path, ws: Path) -> None:
    """What ``git clone`` of the checkout gives (the tracked files, as they are in the working tree)."""
    tracked = subprocess.run(['git', 'ls-files', '-z'], cwd=repo, capture_output=True, text=True)
    names = [n for n in tracked.stdout.split('\0') if n] if tracked.returncode == 0 else []
    if not names:  # not a git checkout: the files a clone has that the tests read
        names = []
        for name in COPIED:
            src = repo / name
            if src.is_dir() and not src.is_symlink():
                shutil.copytree(src, ws / name, ignore=IGNORED)
            elif src.exists() or src.is_symlink():
                names.append(name)
    for name in names:
        src, dst = repo / name, ws / name
        dst.parent.mkdir(parents=True, exist_ok=True)
        if src.is_symlink():
            dst.symlink_to(os.readlink(src))
        elif src.is_file():
            shutil.copy2(src, dst)


def shell_env(ws: Path, base: dict[str, str] | None = None) -> dict[str, str]:
    """A new shell's environment: nothing of the venv or of ROS set, colcon's user defaults in ``ws``."""
    env = dict(base or os.environ)
    for key in ('AMENT_PREFIX_PATH', 'CMAKE_PREFIX_PATH', 'PYTHONPATH', 'VIRTUAL_ENV', 'COLCON_DEFAULTS_FILE',
                'COLCON_PREFIX_PATH', 'LD_LIBRARY_PATH', '_ROS_WHEELS_BOOTSTRAP_COMPLETE'):  # re-exec marker
        env.pop(key, None)
    venv_bin = str(Path(sys.prefix) / 'bin')
    env['PATH'] = os.pathsep.join(p for p in env['PATH'].split(os.pathsep) if p != venv_bin)
    env['COLCON_HOME'] = str(ws / '.colcon')
    return env


def colcon(ws: Path, *args: str, env: dict[str, str], timeout: float = 600) -> subprocess.CompletedProcess:
    """``colcon ARGS`` in ``ws`` after the README's activation (``. .venv/bin/activate``, ``AMENT_PREFIX_PATH``)."""
    script = '. .venv/bin/activate && export AMENT_PREFIX_PATH="$PWD/.venv" && exec colcon "$@"'
    return subprocess.run(['sh', '-c', script, 'sh', *args], cwd=ws, env=env, capture_output=True, text=True,
                          timeout=timeout)


def ws_env(ws: Path, base: dict[str, str] | None = None) -> dict[str, str]:
    """``base`` with the venv's python3 first on PATH (an activated venv) and colcon's defaults in ``ws``."""
    env = {**(base or os.environ), 'COLCON_HOME': str(ws / '.colcon'),
           'PATH': f'{Path(sys.executable).parent}{os.pathsep}{os.environ["PATH"]}'}
    env.pop('COLCON_DEFAULTS_FILE', None)
    return env


def follow_readme(repo: Path, ws: Path, env: dict[str, str]) -> subprocess.CompletedProcess:
    """Clone into ``ws`` and run the README's colcon steps there, as written (but ``make install``)."""
    fresh_clone(repo, ws)
    steps = readme_steps(ws / 'README.md')
    assert MAKE_INSTALL in steps, steps
    script = ['set -ex', *[f'ln -s "{sys.prefix}" .venv' if step == MAKE_INSTALL else step for step in steps]]
    return subprocess.run(['sh', '-c', '\n'.join(script)], cwd=ws, env=shell_env(ws, env), capture_output=True,
                          text=True, timeout=1800)


@pytest.fixture(scope='module')
def readme_run(repo, tmp_path_factory, env_factory) -> tuple[Path, subprocess.CompletedProcess]:
    ws = tmp_path_factory.mktemp('colcon_ws')
    return ws, follow_readme(repo, ws, env_factory())


@pytest.fixture(scope='module')
def workspace(readme_run) -> Path:
    ws, proc = readme_run
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-6000:]
    return ws


@pytest.fixture(scope='module')
def symlink_workspace(repo, tmp_path_factory, env_factory) -> Path:
    ws = tmp_path_factory.mktemp('colcon_ws_symlink')
    fresh_clone(repo, ws)
    (ws / '.venv').symlink_to(sys.prefix)
    proc = colcon(ws, 'build', '--symlink-install', '--packages-ignore', 'tf2_msgs', 'track_msgs',
                  env=shell_env(ws, env_factory()))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return ws


def test_the_readme_steps_run_as_written(readme_run):
    """Every line of the README's block ran (sh -e) and did what it says: the interface packages built too,
    the node's help came from install/, colcon test passed and colcon test-result found it."""
    ws, proc = readme_run
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-6000:]
    for pkg in ('tf2_msgs', 'track_msgs', 'track_core', 'track_msgs_py', 'track_nodes', 'track_experiments'):
        assert (ws / 'install' / pkg).is_dir(), pkg
    assert 'usage: ros2 run track_nodes demo_target' in proc.stdout, proc.stdout
    assert '0 errors, 0 failures' in proc.stdout, proc.stdout[-3000:]


def test_without_ament_prefix_path_the_interfaces_do_not_build(repo, tmp_path, env_factory):
    """Why the README exports AMENT_PREFIX_PATH: `activate` does not set it, and tf2_msgs then finds no
    rosidl type support (what a user saw). Configuring tf2_msgs alone shows it, in seconds."""
    ws = tmp_path / 'ws'
    ws.mkdir()
    shutil.copytree(repo / 'interfaces/tf2_msgs', ws / 'tf2_msgs')
    (ws / '.venv').symlink_to(sys.prefix)
    script = '. .venv/bin/activate && exec colcon build --packages-select tf2_msgs'
    proc = subprocess.run(['sh', '-c', script], cwd=ws, env=shell_env(ws, env_factory()), capture_output=True,
                          text=True, timeout=600)
    assert proc.returncode != 0 and 'tf2_msgs' in proc.stdout + proc.stderr


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
    env = shell_env(workspace)
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

"""The install prefix has the ament layout `ros2 run` needs (docs/DESIGN.md, "Install, `ros2 run` and colcon").

The prefix is the one the ament index gives (conftest ``prefix``): ``.venv`` under ``make test``,
the workspace's ``install/`` under ``colcon test``. The shims must run under either.
"""

import os
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from ament_index_python.packages import get_package_prefix

PKGS = ('track_core', 'track_msgs_py', 'track_nodes', 'track_experiments')
FAKE_PYTHON = '#!/bin/sh\necho "{who} $*"\n'


@pytest.mark.parametrize('pkg', PKGS)
def test_ament_index_marker_and_package_xml(pkg):
    pkg_prefix = Path(get_package_prefix(pkg))
    assert (pkg_prefix / 'share/ament_index/resource_index/packages' / pkg).is_file()
    root = ET.parse(pkg_prefix / 'share' / pkg / 'package.xml').getroot()
    assert root.get('format') == '3'
    assert root.findtext('name') == pkg
    assert root.find('export/build_type').text == 'ament_python'


def test_every_shim_runs_a_registered_executable(prefix):
    from track_nodes.registry import executables, main_of

    shims = sorted((prefix / 'lib/track_nodes').iterdir())
    assert {s.name for s in shims} == set(executables())  # one shim per executable, none missing or stale
    for shim in shims:
        assert os.access(shim, os.X_OK), f'{shim} is not executable'
        text = shim.read_text()
        assert text.startswith('#!/bin/sh') and f'-m track_nodes {shim.name} ' in text
        assert callable(main_of(shim.name))


def _copy_shims(prefix: Path, to: Path, interpreter: str | None) -> list[Path]:
    """The installed shims in a fresh prefix ``to`` (``to/bin/python3`` = ``interpreter`` if given)."""
    (to / 'lib').mkdir(parents=True)
    shutil.copytree(prefix / 'lib/track_nodes', to / 'lib/track_nodes', symlinks=False)
    if interpreter is not None:
        (to / 'bin').mkdir()
        (to / 'bin/python3').write_text(interpreter)
        (to / 'bin/python3').chmod(0o755)
    return sorted((to / 'lib/track_nodes').iterdir())


def _fake_path(tmp_path: Path) -> str:
    """A PATH whose only python3 says who it is."""
    fake = tmp_path / 'fakebin'
    fake.mkdir()
    (fake / 'python3').write_text(FAKE_PYTHON.format(who='path-python3'))
    (fake / 'python3').chmod(0o755)
    return f'{fake}{os.pathsep}/usr/bin{os.pathsep}/bin'


def test_shims_run_the_interpreter_beside_them(prefix, tmp_path):
    """A venv prefix: ``<prefix>/bin/python3`` wins over python3 on PATH."""
    shims = _copy_shims(prefix, tmp_path / 'venv', FAKE_PYTHON.format(who='prefix-python3'))
    env = {**os.environ, 'PATH': _fake_path(tmp_path)}
    for shim in shims:
        out = subprocess.run([shim, '--ros-args', '-p', 'x:=1'], capture_output=True, text=True, env=env, timeout=10)
        assert (out.returncode, out.stdout) == (0, f'prefix-python3 -m track_nodes {shim.name} --ros-args -p x:=1\n')


def test_shims_without_an_interpreter_beside_them_use_python3_on_path(prefix, tmp_path):
    """A colcon prefix (install/track_nodes) has no bin/python3: the environment's python3 runs the node."""
    shims = _copy_shims(prefix, tmp_path / 'install/track_nodes', None)
    env = {**os.environ, 'PATH': _fake_path(tmp_path)}
    for shim in shims:
        out = subprocess.run([shim, 'a b'], capture_output=True, text=True, env=env, timeout=10)
        assert (out.returncode, out.stdout) == (0, f'path-python3 -m track_nodes {shim.name} a b\n'), out.stderr


def test_a_shim_in_a_prefix_without_python_runs_the_node(prefix, tmp_path):
    """End to end with the real interpreter found on PATH (what an activated venv or a ROS machine gives)."""
    (shim,) = (s for s in _copy_shims(prefix, tmp_path / 'install/track_nodes', None) if s.name == 'demo_target')
    bad = tmp_path / 'bad.yaml'
    bad.write_text('demo_target:\n  ros__parameters:\n    period: -1.0\n')
    env = {**os.environ, 'PATH': f'{Path(sys.executable).parent}{os.pathsep}{os.environ["PATH"]}',
           'ROS_DOMAIN_ID': '97', 'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST'}
    proc = subprocess.run([shim, '--ros-args', '--params-file', str(bad)], capture_output=True, text=True,
                          timeout=60, env=env)
    assert proc.returncode == 2, proc.stderr
    assert 'period' in proc.stderr and 'Traceback' not in proc.stderr


def test_unknown_executable_is_one_line_and_exit_2(venv):
    proc = subprocess.run([str(venv / 'bin/python3'), '-m', 'track_nodes', 'no_such_node'], capture_output=True,
                          text=True, timeout=60)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1 and 'no_such_node' in proc.stderr


def test_every_scenario_node_has_a_shim(prefix):
    from track_nodes.launch.scenario import load_scenario

    configs = sorted((prefix / 'share/track_nodes/config').glob('*.yaml'))
    assert configs, 'no scenario configs installed'
    for cfg in configs:
        for spec in load_scenario(str(cfg)).nodes:
            assert (prefix / 'lib/track_nodes' / spec.executable).is_file(), f'{cfg.name}: {spec.executable}'
            assert spec.executable == spec.node_class().DEFAULT_NAME


def test_shim_runs_a_node_with_bad_params_file_message(prefix, tmp_path):
    """The shim path works like `ros2 run`: a bad parameter value stops the node with one line."""
    bad = tmp_path / 'bad.yaml'
    bad.write_text('demo_target:\n  ros__parameters:\n    period: -1.0\n')
    env = {**os.environ, 'ROS_DOMAIN_ID': '97', 'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST'}
    proc = subprocess.run([str(prefix / 'lib/track_nodes/demo_target'), '--ros-args', '--params-file', str(bad)],
                          capture_output=True, text=True, timeout=60, env=env)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and 'period' in lines[0] and '-1' in lines[0] and 'allowed' in lines[0]
    assert 'Traceback' not in proc.stderr


def test_launch_files_installed(prefix):
    launch = sorted(p.name for p in (prefix / 'share/track_nodes/launch').glob('*.launch.py'))
    assert 'demo.launch.py' in launch


def test_tests_run_installed_executables_from_the_ament_index_prefix(repo):
    """A test running a shim or console script from the venv (lib/track_nodes, bin/track-*) would test the venv's
    copy under ``colcon test``, or find nothing on a ROS machine: installed executables come from ``prefix``."""
    import re

    pattern = re.compile(r"""(venv|VENV|sys\.prefix\)?)\s*/\s*['"](lib/track_nodes|bin/track-)""")
    offenders = [f'{path.relative_to(repo)}:{n}' for path in sorted((repo / 'test').rglob('*.py'))
                 for n, line in enumerate(path.read_text().splitlines(), 1) if pattern.search(line)]
    assert not offenders, offenders


def test_scenarios_come_from_the_prefix_the_ament_index_gives(prefix, tmp_path, monkeypatch):
    """An overlay sourced after the workspace puts another prefix first on AMENT_PREFIX_PATH."""
    from track_nodes.launch.scenario import find_scenario

    ws = tmp_path / 'ws/install/track_nodes'
    shutil.copytree(prefix / 'share/track_nodes/config', ws / 'share/track_nodes/config')
    (ws / 'share/ament_index/resource_index/packages').mkdir(parents=True)
    (ws / 'share/ament_index/resource_index/packages/track_nodes').touch()
    (tmp_path / 'overlay/share').mkdir(parents=True)
    monkeypatch.setenv('AMENT_PREFIX_PATH', os.pathsep.join([str(tmp_path / 'overlay'), str(ws), sys.prefix]))
    monkeypatch.chdir(tmp_path)  # no ./config here
    assert find_scenario('demo') == (ws / 'share/track_nodes/config/demo.yaml').resolve()

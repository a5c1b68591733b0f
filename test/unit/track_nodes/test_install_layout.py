"""The installed venv has the ament layout `ros2 run` needs (DESIGN.md, "Install and ros2 run")."""

import os
import subprocess
import xml.etree.ElementTree as ET

import pytest

PKGS = ('track_core', 'track_msgs_py', 'track_nodes')


@pytest.mark.parametrize('pkg', PKGS)
def test_ament_index_marker_and_package_xml(venv, pkg):
    assert (venv / 'share/ament_index/resource_index/packages' / pkg).is_file()
    root = ET.parse(venv / 'share' / pkg / 'package.xml').getroot()
    assert root.get('format') == '3'
    assert root.findtext('name') == pkg
    assert root.find('export/build_type').text == 'ament_python'


def test_every_shim_runs_a_registered_executable(venv):
    from track_nodes.registry import executables, main_of

    shims = sorted((venv / 'lib/track_nodes').iterdir())
    assert {s.name for s in shims} == set(executables())  # one shim per executable, none missing or stale
    for shim in shims:
        assert os.access(shim, os.X_OK), f'{shim} is not executable'
        text = shim.read_text()
        assert text.startswith('#!/bin/sh') and f'-m track_nodes {shim.name} ' in text
        assert callable(main_of(shim.name))


def test_unknown_executable_is_one_line_and_exit_2(venv):
    proc = subprocess.run([str(venv / 'bin/python3'), '-m', 'track_nodes', 'no_such_node'], capture_output=True,
                          text=True, timeout=60)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1 and 'no_such_node' in proc.stderr


def test_every_scenario_node_has_a_shim(venv):
    from track_nodes.launch.scenario import load_scenario

    configs = sorted((venv / 'share/track_nodes/config').glob('*.yaml'))
    assert configs, 'no scenario configs installed'
    for cfg in configs:
        for spec in load_scenario(str(cfg)).nodes:
            assert (venv / 'lib/track_nodes' / spec.executable).is_file(), f'{cfg.name}: {spec.executable}'
            assert spec.executable == spec.node_class().DEFAULT_NAME


def test_shim_runs_a_node_with_bad_params_file_message(venv, tmp_path):
    """The shim path works like `ros2 run`: a bad parameter value stops the node with one line."""
    bad = tmp_path / 'bad.yaml'
    bad.write_text('demo_target:\n  ros__parameters:\n    period: -1.0\n')
    env = {**os.environ, 'ROS_DOMAIN_ID': '97', 'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST'}
    proc = subprocess.run([str(venv / 'lib/track_nodes/demo_target'), '--ros-args', '--params-file', str(bad)],
                          capture_output=True, text=True, timeout=60, env=env)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and 'period' in lines[0] and '-1' in lines[0] and 'allowed' in lines[0]
    assert 'Traceback' not in proc.stderr


def test_launch_files_installed(venv):
    launch = sorted(p.name for p in (venv / 'share/track_nodes/launch').glob('*.launch.py'))
    assert 'demo.launch.py' in launch

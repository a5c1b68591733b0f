"""The installed venv has the ament layout `ros2 run` needs (DESIGN.md, "Install and ros2 run")."""

import importlib
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


def test_every_shim_runs_an_existing_module(venv):
    shims = sorted((venv / 'lib/track_nodes').iterdir())
    assert {s.name for s in shims} >= {'demo_target', 'demo_tracker', 'recorder', 'player', 'bag_recover'}
    for shim in shims:
        assert os.access(shim, os.X_OK), f'{shim} is not executable'
        text = shim.read_text()
        assert text.startswith('#!/bin/sh') and f'-m track_nodes.{shim.name} ' in text
        importlib.util.find_spec(f'track_nodes.{shim.name}')


def test_every_scenario_node_has_a_shim(venv):
    from track_nodes.scenario import load_scenario

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

"""track_core must never import rclpy, the upper layers, or the experiments' plotting and progress bars,
directly or indirectly (it installs with numpy and scipy only)."""

import ast
import json
import subprocess
import sys
from pathlib import Path

import track_core

FORBIDDEN = ('rclpy', 'rosidl', 'rosbags', 'mcap', 'track_msgs_py', 'track_nodes', 'track_experiments',
             'matplotlib', 'tqdm')
FORBIDDEN_SUFFIX = '_msgs'


def _forbidden(mod: str) -> bool:
    top = mod.split('.', maxsplit=1)[0]
    return top.startswith(FORBIDDEN) or top.endswith(FORBIDDEN_SUFFIX)


def test_importing_every_track_core_module_loads_no_ros():
    """Import every submodule in a fresh interpreter and inspect sys.modules (indirect imports too)."""
    code = (
        'import importlib, pkgutil, sys, json, track_core\n'
        'mods = [m.name for m in pkgutil.walk_packages(track_core.__path__, "track_core.")]\n'
        'for m in mods: importlib.import_module(m)\n'
        'print(json.dumps({"imported": mods, "loaded": sorted(sys.modules)}))\n'
    )
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True, check=True)
    result = json.loads(out.stdout.strip().splitlines()[-1])
    assert 'track_core.filters.kalman' in result['imported']  # the walk really found the modules
    bad = [m for m in result['loaded'] if _forbidden(m)]
    assert not bad, f'track_core pulled in ROS or upper-layer modules: {bad[:10]}'
    heavy = [m for m in result['loaded'] if m.split('.')[0] in ('matplotlib', 'tqdm')]
    assert not heavy, f'importing track_core loaded plotting or progress bars: {heavy[:5]}'


def test_no_forbidden_import_statements_in_source():
    root = Path(track_core.__file__).parent
    offenders = []
    for path in root.rglob('*.py'):
        for node in ast.walk(ast.parse(path.read_text())):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                names = [node.module]
            offenders += [f'{path.name}: {n}' for n in names if _forbidden(n)]
    assert not offenders, offenders


def test_forbidden_rule_catches_ros_modules():
    assert _forbidden('rclpy.node') and _forbidden('nav_msgs.msg') and _forbidden('track_nodes.launch')
    assert not _forbidden('numpy') and not _forbidden('track_core.filters')
    assert _forbidden('matplotlib.pyplot') and _forbidden('track_experiments.cli')

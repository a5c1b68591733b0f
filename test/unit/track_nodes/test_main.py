"""``python -m track_nodes``: how a node process leaves, and its ``--help`` without the heavy imports."""

import json
import os
import subprocess
import sys

# A Ctrl-C that lands while rclpy is being imported leaves a half-imported module behind; here a
# blocked rclpy import stands for it. The exit must not import anything more (no second traceback).
HALF_IMPORTED = """
import sys
import track_nodes.__main__ as m
sys.modules['rclpy'] = None  # any later 'import rclpy' raises
m._exit(130)
"""


def test_exit_after_a_ctrl_c_while_importing_imports_nothing():
    proc = subprocess.run([sys.executable, '-c', HALF_IMPORTED], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 130, proc.stderr
    assert 'Traceback' not in proc.stderr, proc.stderr


# A Ctrl-C that lands while ``python -m track_nodes`` imports its own modules (seconds on a busy machine,
# before rclpy takes over SIGINT): a finder raises KeyboardInterrupt at the registry's import.
CTRL_C_WHILE_IMPORTING = """
import runpy, sys
class CtrlC:
    def find_spec(self, name, path=None, target=None):
        if name == 'track_nodes.registry':
            raise KeyboardInterrupt
sys.meta_path.insert(0, CtrlC())
sys.argv = ['track_nodes', 'demo_target']
runpy.run_module('track_nodes', run_name='__main__', alter_sys=True)
"""


def test_a_ctrl_c_while_the_executable_is_imported_exits_130_without_a_traceback():
    proc = subprocess.run([sys.executable, '-c', CTRL_C_WHILE_IMPORTING], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 130 and 'Traceback' not in proc.stderr, proc.stderr


# ``python -m track_nodes EXE --help`` as the shims run it; then what it imported (the heavy ones).
HELP_AND_MODULES = """
import contextlib, io, json, sys
import track_nodes.__main__ as m
out = io.StringIO()
with contextlib.redirect_stdout(out):
    rc = m.main(sys.argv[1:])
heavy = sorted(n for n in sys.modules if n.split('.')[0] in ('rclpy', 'numpy', 'scipy', 'track_core', 'track_msgs_py')
               or n in ('track_nodes.base.node', 'track_nodes.base.params'))
print(json.dumps([rc, out.getvalue(), heavy]))
"""


def _help(exe: str, env: dict) -> tuple[int, str, list[str]]:
    proc = subprocess.run([sys.executable, '-c', HELP_AND_MODULES, exe, '--help'], capture_output=True, text=True,
                          timeout=300, env=env)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return tuple(json.loads(proc.stdout.strip().splitlines()[-1]))


def test_help_answers_without_importing_rclpy_or_the_cores(tmp_path):
    """The first ``--help`` of an executable builds its text (importing its node); every later one, with the
    same sources, prints the same text without importing rclpy, numpy, scipy or the cores: a node, a tool with
    its own argparse usage and a managed node."""
    env = {**os.environ, 'TRACK_NODES_CACHE': str(tmp_path)}
    for exe in ('fusion', 'foxglove_bridge', 'lifecycle_slam'):
        rc, first, heavy = _help(exe, env)
        assert rc == 0 and first.startswith('usage:') and 'rclpy' in heavy, (exe, first[:200])
        rc, again, heavy = _help(exe, env)
        assert rc == 0 and again == first, exe
        assert heavy == [], (exe, heavy)

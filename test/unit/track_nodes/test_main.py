"""``python -m track_nodes``: how a node process leaves."""

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

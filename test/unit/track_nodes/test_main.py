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

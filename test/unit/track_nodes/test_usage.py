"""``--help`` on every executable: usage on stdout, exit 0, and no node started (rclpy never initialised)."""

from __future__ import annotations

import json
import subprocess
import sys

from track_nodes.base.params import all_specs
from track_nodes.base.usage import usage, wants_help
from track_nodes.registry import executables, node_class

# Each executable's main with --help in this one interpreter; SystemExit is argparse's exit.
EVERY_HELP = """
import contextlib, io, json, sys
import rclpy
import track_nodes.__main__ as m
from track_nodes.registry import executables
out = {}
for exe in executables():
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        try:
            rc = m.main([exe, '--help'])
        except SystemExit as exc:
            rc = exc.code
    out[exe] = [rc, buf.getvalue(), rclpy.ok()]
print(json.dumps(out))
"""


def test_every_executable_prints_usage_and_exits_0_without_starting():
    proc = subprocess.run([sys.executable, '-c', EVERY_HELP], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    seen = json.loads(proc.stdout.strip().splitlines()[-1])
    assert set(seen) == set(executables())
    for exe, (rc, text, started) in seen.items():
        assert rc == 0, (exe, rc)
        assert text.startswith('usage:'), (exe, text[:200])
        assert not started, f'{exe}: --help initialised rclpy'


def test_help_lists_every_declared_parameter_with_its_default():
    cls = node_class('fusion')
    text = usage('fusion', cls)
    for spec in all_specs(cls.Params):
        assert f'  {spec.name} = {spec.default!r}' in text
    assert 'rate = 2.0  ([0.01, 100]; live)' in text


def test_help_after_ros_args_is_rcl_s():
    assert wants_help(['fusion', '--help'])
    assert wants_help(['fusion', '-h', '--ros-args', '-p', 'rate:=1.0'])
    assert not wants_help(['fusion', '--ros-args', '--help'])
    assert not wants_help(['fusion'])

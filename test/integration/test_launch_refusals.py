"""What the launcher refuses before it builds anything (``track_nodes.launch.preflight``, ``scenario``): one
line on stderr and exit 2, never a traceback, and no bag left behind."""

from __future__ import annotations

import contextlib
import subprocess
import sys
from pathlib import Path

import pytest

RUN = ('--duration', '1', '--rate', '20')
TYPED = '/**/demo_target:\n  ros__parameters:\n    period: "abc"\n'  # the scenario gives period: 0.1 (a double)


def refused(repo: Path, cwd: Path, env: dict, *args: str, scenario: str | None = None) -> str:
    """Run the launcher on ``scenario`` (the demo by default); assert one line, exit 2; → the line."""
    cmd = [sys.executable, '-m', 'track_nodes.launch', scenario or str(repo / 'config/demo.yaml'), *args]
    proc = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 2, proc.stderr
    assert 'Traceback' not in proc.stderr, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith('track_nodes.launch: '), proc.stderr
    return lines[0]


def test_a_binary_scenario_file(tmp_path, env_factory, repo):
    (tmp_path / 'binary.yaml').write_bytes(bytes(range(256)) * 4)
    line = refused(repo, tmp_path, env_factory(), scenario=str(tmp_path / 'binary.yaml'))
    assert 'binary.yaml' in line and 'cannot read scenario' in line, line


def test_a_params_file_with_a_yaml_syntax_error(tmp_path, env_factory, repo):
    (tmp_path / 'broken.yaml').write_text('/**/demo_target:\n  ros__parameters:\n    period: [1\n')
    line = refused(repo, tmp_path, env_factory(), '--params', 'broken.yaml', *RUN)
    assert '--params broken.yaml' in line and 'not valid YAML' in line, line


def test_a_binary_params_file(tmp_path, env_factory, repo):
    (tmp_path / 'binary.yaml').write_bytes(bytes(range(256)))
    line = refused(repo, tmp_path, env_factory(), '--params', 'binary.yaml', *RUN)
    assert '--params binary.yaml' in line and 'not a text file' in line, line


@pytest.mark.parametrize('layers', [('typed.yaml',), ('ok.yaml', 'typed.yaml')], ids=['alone', 'layered'])
def test_a_wrong_typed_value_over_the_scenario_is_refused_alone_and_layered(tmp_path, env_factory, repo, layers):
    """rcl merges a value of another type into the earlier one and rclpy keeps the earlier: refused instead."""
    (tmp_path / 'typed.yaml').write_text(TYPED)
    (tmp_path / 'ok.yaml').write_text('/**/demo_target:\n  ros__parameters:\n    period: 0.2\n')
    line = refused(repo, tmp_path, env_factory(), *[a for f in layers for a in ('--params', f)], *RUN)
    assert '--params typed.yaml' in line and 'period' in line and 'abc' in line and 'double' in line, line


def test_a_wrong_typed_value_under_a_later_layer_is_refused_too(tmp_path, env_factory, repo):
    (tmp_path / 'typed.yaml').write_text(TYPED)
    (tmp_path / 'later.yaml').write_text('/**/demo_target:\n  ros__parameters:\n    period: 0.2\n')
    line = refused(repo, tmp_path, env_factory(), '--params', 'typed.yaml', '--params', 'later.yaml', *RUN)
    assert '--params typed.yaml' in line, line  # checked against the scenario below it, before later.yaml


@pytest.mark.parametrize('where', ['/proc/bag', 'a_file/bag'], ids=['proc', 'under-a-file'])
def test_record_where_no_bag_can_be_written(tmp_path, env_factory, repo, where):
    (tmp_path / 'a_file').write_text('not a directory\n')
    line = refused(repo, tmp_path, env_factory(), '--record', where, *RUN)
    assert f'--record {where}' in line, line
    assert (tmp_path / 'a_file').read_text() == 'not a directory\n'


@contextlib.contextmanager
def full_disk(where: Path):
    """A 64 KiB tmpfs at ``where``, filled to the last block (root only, as test_recorder's small_disk)."""
    where.mkdir()
    res = subprocess.run(['mount', '-t', 'tmpfs', '-o', 'size=64k', 'tmpfs', str(where)], capture_output=True,
                         text=True)
    if res.returncode != 0:
        pytest.skip(f'cannot mount a small tmpfs to fill: {res.stderr.strip() or res.returncode}')
    try:
        with contextlib.suppress(OSError), open(where / 'fill', 'wb') as f:
            while True:
                f.write(b'\0' * 4096)
                f.flush()
        yield where
    finally:
        subprocess.run(['umount', '-l', str(where)], capture_output=True)


@pytest.mark.parametrize('mode', [(), ('--processes',)], ids=['one-process', 'processes'])
def test_a_disk_full_at_start_leaves_no_bag(tmp_path, env_factory, repo, mode):
    with full_disk(tmp_path / 'disk') as disk:
        line = refused(repo, tmp_path, env_factory(), '--record', 'disk/run', *mode, *RUN)
        assert 'no room' in line and 'disk' in line, line
        assert sorted(p.name for p in disk.iterdir()) == ['fill']  # no bag directory, no 43-byte .mcap

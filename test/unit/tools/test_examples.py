"""examples/: every script runs to the end, writes its figure and prints a result within the method's bound.

Each bound comes from the method, not from a past run: a consistent filter's NEES is a χ² draw (its
99.9 % quantile), an honest pair's GLR score is uniform on (0, 1), disjoint 2σ ellipses score exactly 0.
"""

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from scipy.stats import chi2

ROOT = Path(__file__).resolve().parents[3]
EXAMPLES = ROOT / 'examples'


def run(name: str, tmp_path: Path) -> str:
    """Run ``examples/<name>`` with a figure into ``tmp_path``; its stdout (exit 0 and a figure checked)."""
    figure = tmp_path / f'{Path(name).stem}.png'
    env = {**os.environ, 'MPLBACKEND': 'Agg'}
    proc = subprocess.run([sys.executable, str(EXAMPLES / name), '--out', str(figure)], capture_output=True,
                          text=True, timeout=600, env=env, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert figure.stat().st_size > 0
    return proc.stdout


def number(pattern: str, text: str) -> float:
    m = re.search(pattern, text)
    assert m, f'{pattern!r} not in:\n{text}'
    return float(m.group(1))


def test_every_example_is_tested_and_listed():
    scripts = sorted(p.name for p in EXAMPLES.glob('*.py'))
    assert len(scripts) >= 5
    assert [s for s in scripts if f'test_{s[:-3]}' not in globals()] == []
    readme = (EXAMPLES / 'README.md').read_text()
    assert all(s in readme for s in scripts)


def test_sonar_smart_target(tmp_path):
    out = run('sonar_smart_target.py', tmp_path)
    assert number(r'final position NEES ([\d.]+)', out) < chi2.ppf(0.999, 2)
    pings = number(r'pings (\d+) of', out)
    assert 1 <= pings < number(r'of (\d+) steps', out)  # eq. 7 pings at the start, and not at every step


def test_fusion_pair_score(tmp_path):
    out = run('fusion_pair_score.py', tmp_path)
    n = number(r'over (\d+) instants', out)
    assert abs(number(r'mean GLR score ([\d.]+)', out) - 0.5) < 4 * (1 / 12 / n) ** 0.5   # U(0, 1): mean 1/2
    assert number(r'decoy pair: largest combined score ([\d.]+)', out) == 0.0            # disjoint ellipses
    assert number(r'decoy pair: .* associated at (\d+)', out) == 0
    assert number(r'ship pair: .* associated at (\d+)', out) > 0


def test_rfid_tag_search(tmp_path):
    out = run('rfid_tag_search.py', tmp_path)
    assert number(r'steps (\d+)', out) < 100                       # the filter stopped the walk, not the limit
    assert number(r'filter distance to the tag ([\d.]+)', out) < 0.5   # its stopping rule: within one step
    assert number(r'true distance to the tag ([\d.]+)', out) < 2.0     # a quarter of the 8 m start


def test_idsq_leader_tracking(tmp_path):
    out = run('idsq_leader_tracking.py', tmp_path)
    rms, size = number(r'RMS error after discovery ([\d.]+)', out), number(r'RMS belief size after discovery ([\d.]+)',
                                                                            out)
    assert rms < 2.0 * size    # a consistent belief: error about its own spread
    assert number(r'mean error after discovery ([\d.]+)', out) < 40.0   # within radio range of the leaders


def test_slam_loop(tmp_path):
    out = run('slam_loop.py', tmp_path)
    assert number(r'final pose NEES ([\d.]+)', out) < chi2.ppf(0.999, 3)
    mapped, seen = number(r'landmarks mapped (\d+)', out), number(r'of (\d+) seen', out)
    assert mapped >= seen
    assert number(r'RMS error ([\d.]+) m', out) < 5 * 0.2   # five range σ


@pytest.mark.parametrize('name', ['sonar_smart_target.py', 'fusion_pair_score.py'])
def test_examples_run_without_a_figure(name, tmp_path):
    proc = subprocess.run([sys.executable, str(EXAMPLES / name)], capture_output=True, text=True, timeout=600,
                          cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert 'figure' not in proc.stdout and not list(tmp_path.iterdir())

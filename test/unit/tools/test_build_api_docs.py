"""tools/build_api_docs.py: the API reference builds without a warning and documents each core's main classes."""

import importlib.util
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]

# page → names that must have an entry (an anchor) on it: what a reader of each core looks for first
MAIN = {
    'track_core/sonar.html': ('SSPF', 'SmartTarget', 'CovarianceScheduler', 'make_tracker'),
    'track_core/geofeasibility.html': ('score', 'ScoreWindow', 'track_score'),
    'track_core/fusion.html': ('PairAssociator', 'TrackReport', 'Instant'),
    'track_core/rfid.html': ('RfidParticleFilter', 'PhaseModel', 'RfidGuidance', 'SimReader'),
    'track_core/idsq.html': ('leader_step', 'SensorLayout', 'SparseBelief', 'encode_handoff'),
    'track_core/slam.html': ('HybridSlam', 'CekfSlam', 'SlamParams'),
    'track_core/filters.html': ('kf_predict', 'unscented_update', 'systematic_resample'),
    'track_msgs_py/topics.html': ('TOPICS', 'TopicSpec'),
    'track_nodes/base.html': ('TrackNode',),
}


def _tool():
    spec = importlib.util.spec_from_file_location('build_api_docs', ROOT / 'tools/build_api_docs.py')
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.mark.timeout(1200)   # imports every module of three packages: about a minute on an idle machine
def test_the_api_reference_builds_without_warnings(tmp_path):
    out = tmp_path / 'api'
    assert _tool().build(out) == []
    assert (out / 'index.html').is_file()
    missing = [f'{page}#{name}' for page, names in MAIN.items() for name in names
               if f'id="{name}"' not in (out / page).read_text()]
    assert missing == []


@pytest.fixture
def broken_package(tmp_path, monkeypatch):
    """A package whose ``__all__`` names nothing and whose docstrings name what does not exist."""
    pkg = tmp_path / 'pkg' / 'brokenpkg'
    pkg.mkdir(parents=True)
    (pkg / '__init__.py').write_text(
        '"""See :func:`missing`, :mod:`.sub` and :class:`.sub.Thing`."""\n'
        'from brokenpkg.sub import Thing\n'
        "__all__ = ['Thing', 'nothing_here']\n")
    (pkg / 'sub.py').write_text(
        '"""Sub."""\n\n\nclass Thing:\n    """A thing that can :meth:`go` but not :meth:`stop`."""\n\n'
        '    def go(self):\n        """Go; see :meth:`Thing.go` and :attr:`size`."""\n')
    monkeypatch.syspath_prepend(str(tmp_path / 'pkg'))
    yield 'brokenpkg'
    for name in [m for m in sys.modules if m.startswith('brokenpkg')]:
        del sys.modules[name]


def test_a_warning_or_a_reference_to_nothing_fails_the_build(broken_package, tmp_path):
    tool = _tool()
    problems = tool.build(tmp_path / 'api', (broken_package,))
    assert any("'nothing_here'" in p for p in problems)   # pdoc's own warning
    assert sorted(p for p in problems if 'names nothing' in p) == [
        "brokenpkg.Thing.go: reference 'size' names nothing",
        "brokenpkg.Thing: reference 'stop' names nothing",
        "brokenpkg: reference 'missing' names nothing",
    ]
    assert tool.main(['--out', str(tmp_path / 'again'), broken_package]) == 1

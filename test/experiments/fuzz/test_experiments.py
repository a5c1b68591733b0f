"""The project's fuzzer against every subscribing node configuration (issue 13).

Each case of ``track_experiments.fuzz.table`` runs once (module cache): its scenario nodes in-process,
``MESSAGES`` bad messages cycling over every class of ``track_experiments.fuzz.generate`` (each class
several times) with the drivers' valid input in between, then valid input alone. Four checks per
node: valid output continues; no NaN/inf in any output; no callback raised (no traceback); and
the log stays throttled. The issue's target is 0.01 lines per bad message at 10,000 messages
(``track-experiment fuzz``); at a few hundred, the throttle's own bound is the check: at most one
line per refusal kind per ``WARN_THROTTLE`` seconds, plus one.
"""

from __future__ import annotations

import math

import pytest

from track_core.ais import default_path
from track_experiments.fuzz.harness import FuzzResult, run_case
from track_experiments.fuzz.table import cases
from track_nodes.base import TrackNode

MESSAGES = 300
AFTER_TIMEOUT = 60.0   # a deadline [wall s] for new valid output after the attack (outputs: every 0.05–1 s)
CASES = cases()
_results: dict[str, FuzzResult] = {}


def fuzzed(name: str, env_factory) -> FuzzResult:
    if name not in _results:
        domain = int(env_factory()['ROS_DOMAIN_ID'])
        _results[name] = run_case(CASES[name], MESSAGES, seed=13, domain_id=domain, after_timeout=AFTER_TIMEOUT)
    res = _results[name]
    assert any(res.output_before.get(t) for t in CASES[name].alive), f'{name}: no valid output before the attack'
    return res


def _log_bound(res: FuzzResult) -> int:
    kinds = max(1, len(res.refusals))
    return kinds * (1 + math.ceil(res.counted_seconds / TrackNode.WARN_THROTTLE))


def _mark(name: str, check: str):
    marks = []
    if CASES[name].scenario in ('ais', 'ais_live'):
        marks.append(pytest.mark.skipif(not default_path().is_file(), reason='shared AIS data not found'))
    return pytest.param(name, id=name, marks=marks)


def _params(check: str):
    return [_mark(name, check) for name in CASES]


@pytest.mark.parametrize('name', _params('alive'))
def test_valid_output_continues(name, env_factory):
    res = fuzzed(name, env_factory)
    assert res.sent == MESSAGES
    assert res.alive, (res.output_before, res.output_after, res.refusals)


@pytest.mark.parametrize('name', _params('finite'))
def test_no_nan_or_inf_in_any_output(name, env_factory):
    res = fuzzed(name, env_factory)
    assert not res.nan_outputs, res.nan_examples[:5]


@pytest.mark.parametrize('name', _params('no_crash'))
def test_no_callback_raises(name, env_factory):
    res = fuzzed(name, env_factory)
    assert not res.crashes, res.crashes[:1]


@pytest.mark.parametrize('name', _params('throttled'))
def test_log_lines_are_throttled(name, env_factory):
    res = fuzzed(name, env_factory)
    assert res.log_lines <= _log_bound(res), (res.log_lines, _log_bound(res), res.refusals)

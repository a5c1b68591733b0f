"""The slam experiments build their filter from the core's profile, as the node does."""

from __future__ import annotations

import numpy as np
import pytest

from track_core.slam.profiles import PROFILES, loop_sim
from track_core.slam.sim import LoopWorld


class _BuiltError(Exception):
    pass


def test_the_loop_experiment_builds_its_filter_from_the_loop_profile(monkeypatch):
    from track_experiments.slam import experiments

    seen = {}

    def spy(pose0, P0, rng, slam, pf, hybrid, **kw):
        seen.update(pose0=pose0, P0=P0, slam=slam, pf=pf, hybrid=hybrid)
        raise _BuiltError

    monkeypatch.setattr(experiments, 'HybridSlam', spy)
    with pytest.raises(_BuiltError):
        experiments._run_loop_once(LoopWorld(), None, True, np.random.default_rng(0))
    prof = PROFILES['loop_sim']()
    assert loop_sim(LoopWorld()) == prof
    assert (seen['slam'], seen['pf'], seen['hybrid']) == (prof.slam, prof.pf, prof.hybrid)
    np.testing.assert_array_equal(seen['pose0'], prof.pose0)
    np.testing.assert_array_equal(seen['P0'], np.diag(prof.pose0_var))

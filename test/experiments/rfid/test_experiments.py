import json
import math

import numpy as np

from track_core.rfid.pf import PFParams
from track_core.rfid.search import run_search
from track_core.rfid.world import WorldParams, office_obstacles
from track_experiments.cli import RunConfig
from track_experiments.rfid.bench import bench
from track_experiments.rfid.experiments import PARTICLES, table1

ROW_KEYS = {'particles', 'steps', 'turns', 'distance_m', 'update_ms', 'success_rate'}


def test_searches_find_the_tag():
    seeds = np.random.SeedSequence(7).spawn(12)
    outs = [run_search(WorldParams(), PFParams(n_particles=100), np.random.default_rng(s)) for s in seeds]
    assert all(o.success for o in outs)
    assert all(o.final_distance_m <= 0.2 for o in outs)
    assert np.mean([o.steps for o in outs]) < 45
    o = outs[0]
    assert o.route.shape == (o.steps + 1, 2) and np.hypot(*o.route[0]) == np.float64(10.0)
    assert math.isfinite(o.update_ms) and o.turns >= 1


def test_obstacle_searches_find_the_tag():
    seeds = np.random.SeedSequence(8).spawn(6)
    outs = [run_search(WorldParams(obstacles=office_obstacles()), PFParams(n_particles=100),
                       np.random.default_rng(s)) for s in seeds]
    assert sum(o.success for o in outs) >= 5


def test_max_steps_ends_a_run_as_failure():
    o = run_search(WorldParams(), PFParams(n_particles=10), np.random.default_rng(0), max_steps=3)
    assert not o.success and o.steps == 3


def test_table1_quick(tmp_path):
    out = table1(RunConfig(quick=True, runs=2, out=tmp_path, show_progress=False))
    assert set(out.data) == {'rows'}
    assert [r['particles'] for r in out.data['rows']] == list(PARTICLES)
    assert all(set(r) == ROW_KEYS for r in out.data['rows'])
    assert all(0.0 <= r['success_rate'] <= 1.0 for r in out.data['rows'])
    assert 'paper' in out.table and '473.9' in out.table and '28.5' in out.table
    assert all(f.exists() and f.stat().st_size > 10_000 for f in out.figures)
    assert json.loads((tmp_path / 'rfid-table1-obstacles.json').read_text())['particles'] == 100
    variants = json.loads((tmp_path / 'rfid-table1-variants.json').read_text())
    assert len(variants) == 5 and 'N=10 prior boosting (init_boost=10)' in variants
    json.dumps(out.data)


def test_bench_quick_keys(tmp_path):
    out = bench(RunConfig(quick=True, out=tmp_path, show_progress=False))
    assert set(out.data) == {'n1000_ms', 'n100000_ms', 'loop_n1000_ms', 'speedup'}
    assert all(math.isfinite(v) and v > 0 for v in out.data.values())
    assert out.data['speedup'] > 1.0 and out.data['n100000_ms'] > out.data['n1000_ms']

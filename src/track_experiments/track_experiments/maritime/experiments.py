"""``track-experiment maritime-seeds``: the maritime network goal on many seeds, without ROS.

Seed s is the scenario ``maritime_yaml(seed=s)`` (sensor layout and sensor noise) with
``smart_target`` seed s + 2 and ``sonar_observer`` seed s + 3 (s = 1 is ``config/maritime.yaml``).
Each seed is simulated (``report.maritime_sim``: the smart target, the observer's SS-PF and the
radar, as the nodes run them), the network replayed on its truths (``report.network_replay``: the
sensors' leader steps and handoffs) and the three tracks scored by the fusion node's associator.

The goal, on every seed: network RTAMS ≤ 15 m, the true sonar|network pair associated at ≥ 95 % of
the instants after both trackers converged, the decoy's pairs never associated. ``--set instants=yes``
adds the per-instant view of ``instants.py`` (the trackers' NEES and the share of runs whose instant
score is below the threshold, measured and if both trackers were consistent). ``--set prior=none``
scores without the fusion's prior (``prior_weight`` 0, the release ratio ε^(1/window)) on the same
runs. The summary also gives the true pair's typical instant score (the geometric mean of its instant
scores floored at ε, over every run and instant): the value the scenario's ``prior_score`` stands for.
"""

from __future__ import annotations

import numpy as np

from track_experiments.cli import Outcome, RunConfig, format_table, set_keys
from track_experiments.maritime.instants import instant_rows, instants_table

RTAMS_GOAL = 15.0
FRACTION_GOAL = 0.95


def seed_scenario(seed: int) -> dict:
    """The parsed maritime scenario of seed ``seed`` (``track_nodes.idsq.scenario_files.seed_scenario``)."""
    from track_nodes.idsq.scenario_files import seed_scenario as scenario

    return scenario(seed)


def run_seed(seed: int, fusion: dict | None = None, instants: bool = False, **tracker) -> dict:
    """Replay summary (``network_replay.summary``) of one seed, ``tracker`` overriding TrackerParams fields
    and ``fusion`` the fusion node's settings (``network_replay.FUSION_KEYS``); with ``instants`` also its
    ``instants.instant_rows`` (key ``per_instant``)."""
    from track_nodes.report import maritime as mar
    from track_nodes.report import maritime_sim, network_replay

    cfg = seed_scenario(seed)
    d = maritime_sim.simulate(cfg)
    setup, layout = network_replay.sensors_of(cfg, **tracker)
    rows = network_replay.replay(d, setup, layout)
    scores = network_replay.fuse(d, rows, **{**network_replay.fusion_of(cfg), **(fusion or {})})
    s = network_replay.summary(d, rows, scores)
    s['true_scores'] = scores.get(tuple(sorted((mar.SONAR_TRACK, mar.NETWORK_TRACK))), np.zeros((0, 2)))[:, 1]
    if instants:
        s['per_instant'] = instant_rows(d, rows, scores, mar.SONAR_TRACK, mar.NETWORK_TRACK, mar.run_start(d))
    s['pings'] = len(d['pings'])  # the observer's active steps: what concealment costs
    s['meets'] = bool(s['rtams'] <= RTAMS_GOAL and s['fraction'] >= FRACTION_GOAL and not s['decoy_ever'])
    return s


def without_prior(fusion: dict) -> dict:
    """Overrides of the fusion settings ``fusion`` (``network_replay.fusion_of``) that drop the prior:
    ``prior_weight`` 0 and the release ratio of the window alone (``associator.release_ratio_of``)."""
    from track_core.fusion.associator import release_ratio_of

    return {'prior_weight': 0.0, 'release_ratio': release_ratio_of(float(fusion.get('floor', 0.0)),
                                                                   int(fusion['window']))}


def typical_score(scores: list[np.ndarray], floor: float) -> tuple[float, int]:
    """Geometric mean of the instant scores (each floored at ``floor``) over all runs, and their number."""
    g = np.concatenate([np.clip(x, 0.0, 1.0) for x in scores]) if scores else np.zeros(0)
    g = np.maximum(g, floor) if floor > 0.0 else g
    return (float(np.exp(np.mean(np.log(g)))) if g.size and np.all(g > 0) else 0.0), int(g.size)


def parse_seeds(text: str) -> list[int]:
    """'1-20' or '3,7,101-110' → the seeds."""
    out: list[int] = []
    for part in text.replace(' ', '').split(','):
        lo, sep, hi = part.partition('-')
        if not lo.isdigit() or (sep and not hi.isdigit()):
            raise ValueError(f'--set seeds={text!r}: allowed comma-separated seeds or ranges a-b (e.g. 1-20,101)')
        out.extend(range(int(lo), int(hi) + 1) if sep else [int(lo)])
    return out


@set_keys(seeds='seeds to run: comma-separated values or ranges a-b (default 1-20; --quick: 1-3)',
          instants='yes: also the per-instant table (NEES of both trackers, share of runs with an instant score '
                   'below the threshold, and that share if both trackers were consistent; default no)',
          prior='scenario: the fusion settings of the scenario (default); none: without its prior (prior_weight 0, '
                'release ratio of the window alone)')
def maritime_seeds(cfg: RunConfig) -> Outcome:
    seeds = parse_seeds(cfg.options.get('seeds', '1-3' if cfg.quick else '1-20'))
    per_instant = cfg.choice('instants', 'no', 'yes')
    prior = cfg.choice('prior', 'scenario', 'none')
    from track_nodes.report.network_replay import fusion_of

    fusion = fusion_of(seed_scenario(seeds[0]))   # every seed's fusion settings are the scenario's
    res = {s: run_seed(s, without_prior(fusion) if prior == 'none' else None, instants=per_instant == 'yes')
           for s in cfg.progress(seeds, desc='maritime-seeds')}
    rows = [[s, r['rtams'], r['error_max'], 100 * r['fraction'], r['instants'], r['decoy_ever'], r['pings'],
             'yes' if r['meets'] else 'NO'] for s, r in res.items()]
    table = format_table(['seed', 'RTAMS m', 'max err m', 'true pair %', 'instants', 'decoy assoc.', 'pings', 'goal'],
                         rows)
    worst_r = max(res, key=lambda s: res[s]['rtams'])
    worst_f = min(res, key=lambda s: res[s]['fraction'])
    met = sum(r['meets'] for r in res.values())
    table += (f'\n{met} of {len(res)} seeds meet the goal (RTAMS <= {RTAMS_GOAL:g} m, true pair >= '
              f'{100 * FRACTION_GOAL:g} % after convergence, decoy never); worst RTAMS seed {worst_r}: '
              f"{res[worst_r]['rtams']:.1f} m (max error {res[worst_r]['error_max']:.1f} m); worst true-pair seed "
              f"{worst_f}: {100 * res[worst_f]['fraction']:.1f} % of {res[worst_f]['instants']} instants; "
              f"{sum(r['pings'] for r in res.values()) / len(res):.2f} pings per run")
    floor = float(fusion.get('floor', 0.0))
    typical, n_inst = typical_score([r['true_scores'] for r in res.values()], floor)
    table += (f'\ntrue pair typical instant score (geometric mean, floored at {floor:.3g}): {typical:.3f} over '
              f'{n_inst} instants' + ('; fusion prior: none' if prior == 'none' else ''))
    data = {'seeds': {str(s): {k: r[k] for k in ('rtams', 'error_max', 'fraction', 'instants', 'decoy_ever', 'meets',
                                                  'bytes_mean', 'pings')} for s, r in res.items()},
            'met': met, 'n_seeds': len(res), 'typical_score': typical, 'prior': prior}
    if per_instant == 'yes':
        rows, data['instants'] = instants_table([r['per_instant'] for r in res.values()])
        table += '\n\nPer instant over the runs (NEES: 2 dof; instant score of the true pair below the threshold):\n'
        table += format_table(['t s', 'runs', 'sonar NEES', 'network NEES', 'score < thr %',
                               'if consistent %'], rows)
    return Outcome(table, data)

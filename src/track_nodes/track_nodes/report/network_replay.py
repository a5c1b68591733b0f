"""Offline replay of the maritime IDSQ network on a recorded bag.

The network is lock-stepped and seeded: its track is a function of the sources' truths, the
simulator's noise and seed (``vehicle_sim``'s section), the sensors' parameters and the layout only.
``replay`` runs ``leader_step`` from the §5.1 start rule on the readings ``vehicle_sim`` draws from
the truths recorded in a maritime bag (the smart target's and the decoy's; each sensor hears its
loudest; ``track_core.idsq.readings``), each as its sensor receives it (a DOA bearing after its
REP-103 round trip), as the sensors' ledger does when no handoff fails and no reading is missing,
and ``fuse`` scores the replayed
track against the recorded sonar and radar tracks with the fusion node's ``PairAssociator`` at
the data instants. With the scenario's own settings both reproduce the bag (estimates bit for bit,
scores to the record's 6 decimals, verdicts exactly: ``test_maritime``), so other settings
(prediction, switching, radio range) are compared on the same truths in seconds, without ROS; the
smart target and the sonar never see the network, so their part of the bag does not change with it.

    python -m track_nodes.report.network_replay BAG --scenario config/maritime.yaml [--set KEY=VALUE]
        [--comm-range R] [--trace]

``--set`` overrides a ``TrackerParams`` field (``prediction=drift``, ``bank_switch=0.2``, ...);
``--trace`` prints one line per instant: leader (A acoustic, D DOA) and its distance to the
target, error, belief σ (major/minor), NEES, stored entries, handoff bytes, fusion instant score,
combined score and verdict of the true pair. Times are seconds from the run's start
(``maritime.run_start``), whose UTC date is printed once before the trace and the summary.

NEES uses ``track_core.metrics.nees_or_nan`` (as the sonar core): a belief that collapsed to one cell has an all-zero
(singular) covariance, so its NEES is undefined. Such steps get NaN, are left out of the NEES mean
and share, and are counted (with the first one's time and reason) in the summary line.
"""

from __future__ import annotations

import argparse
import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

from track_core.fusion import AssociatorConfig, PairAssociator, TrackReport
from track_core.idsq.handoff import decode_handoff
from track_core.idsq.leader_protocol import (
    SensorSetup,
    elected,
    received_z,
    stamp_of_step,
    start_amplitudes,
    start_belief,
)
from track_core.idsq.models import DEG, SimNoise
from track_core.idsq.network import SensorLayout
from track_core.idsq.readings import sensor_reading
from track_core.idsq.tracker import leader_step
from track_core.metrics import nees_or_nan
from track_nodes.base.scenario_file import section_node
from track_nodes.fusion.params import ASSOCIATOR_PARAMS, associator_config
from track_nodes.idsq.params import SENSOR_PARAMS, sensor_setup
from track_nodes.idsq.vehicle_sim import VehicleSimParams
from track_nodes.report import maritime as mar

FUSION_SOURCE = {mar.SONAR_TRACK: '/sonar/estimate', mar.NETWORK_TRACK: '/idsq/estimate', mar.RADAR_DECOY: '/radar'}


@dataclass(frozen=True)
class ReplaySetup:
    """The sensors' setup (``SensorSetup`` of sensor 0) and the simulator's noise and seed (``vehicle_sim``)."""

    sensor: SensorSetup
    noise: SimNoise
    seed: int

    tracker = property(lambda self: self.sensor.tracker)
    grid = property(lambda self: self.sensor.grid)
    start = property(lambda self: self.sensor.start)
    selection = property(lambda self: self.sensor.selection)


def sensors_of(scenario: Path | dict, comm_range: float | None = None, **tracker) -> tuple[ReplaySetup, SensorLayout]:
    """(ReplaySetup: sensor 0's SensorSetup with ``tracker`` overrides and vehicle_sim's noise and seed,
    SensorLayout) of a maritime scenario file (its path, or its parsed dict)."""
    cfg = scenario if isinstance(scenario, dict) else yaml.safe_load(Path(scenario).read_text())
    shared = cfg.get('/**', {}).get('ros__parameters', {})  # what every node gets, as ROS gives it
    entries = sorted(({**shared, **v['ros__parameters']} for k, v in cfg.items()
                      if section_node(k).startswith('sensor_')), key=lambda e: e['id'])
    first = entries[0]
    cls = SENSOR_PARAMS[first['type']]
    p = cls(**{f.name: first[f.name] for f in dataclasses.fields(cls) if f.name in first})
    setup = sensor_setup(p, np.asarray(p.position, dtype=float))
    setup = dataclasses.replace(setup, tracker=dataclasses.replace(setup.tracker, **tracker))
    sim = {**shared, **next((v['ros__parameters'] for k, v in cfg.items() if section_node(k) == 'vehicle_sim'), {})}
    v = VehicleSimParams(**{f.name: sim[f.name] for f in dataclasses.fields(VehicleSimParams) if f.name in sim})
    noise = SimNoise(amplitude=v.amplitude, sigma_a=v.noise_sigma_a, sigma_doa=v.noise_sigma_doa_deg * DEG)
    layout = SensorLayout(np.array([e['position'] for e in entries], dtype=float),
                          np.array([e['type'] == 'doa' for e in entries]),
                          float(p.comm_range if comm_range is None else comm_range))
    return ReplaySetup(setup, noise, int(v.seed)), layout


def replay(d: dict, setup: ReplaySetup, layout: SensorLayout) -> list[dict]:
    """One row per network step: stamp, leader, estimate, belief and handoff size (``maritime.load`` data ``d``)."""
    dt, origin = setup.tracker.dt, d.get('origin', 0.0)
    by_step: dict[int, dict[str, np.ndarray]] = {}
    for key in (mar.RADAR_DECOY, mar.NETWORK_TRACK):  # truth topic order: /radar/truth < /sonar/target/truth
        for t, xy in zip(*d['truth'][key], strict=True):
            by_step.setdefault(round((t - origin) / dt) - 1, {})[key] = xy
    steps = sorted(s for s, v in by_step.items() if s >= 0 and len(v) == 2)
    truth = {s: np.array([by_step[s][mar.RADAR_DECOY], by_step[s][mar.NETWORK_TRACK]]) for s in steps}
    amps = start_amplitudes(layout, truth[steps[0]], setup.noise, setup.seed)  # the election's step-0 amplitudes
    leader, prev = elected(layout, amps), None
    belief = start_belief(layout, leader, amps, setup.grid, setup.tracker, setup.start)
    rows = []
    for s in steps:  # the leader of each step (one after the other: a step needs the previous handoff)
        pos, doa = layout.positions[leader], bool(layout.is_doa[leader])
        z = received_z(sensor_reading(truth[s], pos, doa, leader, s, setup.noise, setup.seed))
        res = leader_step(belief, z, leader, layout, setup.tracker, step=s, previous=prev, selection=setup.selection)
        target = by_step[s][mar.NETWORK_TRACK]
        rows.append({'t': stamp_of_step(s, dt, origin), 'leader': leader, 'doa': doa,
                     'range': float(np.hypot(*(pos - target))),
                     'mean': res.estimate.mean, 'cov': res.estimate.cov, 'size': res.estimate.size,
                     'bytes': len(res.payload), 'truth': target})
        belief = decode_handoff(res.payload).belief()  # what the next leader receives (float32 body)
        prev, leader = leader, res.next_leader
    return rows


FUSION_KEYS = ASSOCIATOR_PARAMS   # the fusion node's parameters that make its associator (``fusion.params``)


def fusion_of(scenario: Path | dict) -> dict:
    """The fusion node's association settings (``FUSION_KEYS``) in a maritime scenario file (path or dict)."""
    cfg = scenario if isinstance(scenario, dict) else yaml.safe_load(Path(scenario).read_text())
    shared = cfg.get('/**', {}).get('ros__parameters', {})  # what every node gets, as ROS gives it
    sec = {**shared, **next((v['ros__parameters'] for k, v in cfg.items() if section_node(k) == 'fusion'), {})}
    return {k: sec[k] for k in FUSION_KEYS if k in sec}


def fusion_config(**fusion) -> AssociatorConfig:
    """The fusion node's ``AssociatorConfig`` of its parameters ``fusion`` (``fusion_of``; the node's defaults
    for the others), built as the node builds it; the replay scores the data's instants, so ``schedule``
    must be ``stamps``."""
    config = associator_config(fusion)
    if config.stamp_rate is None:
        raise ValueError("network_replay scores at the data's instants: the fusion settings need schedule: stamps")
    return config


def fuse(d: dict, rows: list[dict], **fusion) -> dict[tuple[str, str], np.ndarray]:
    """Scores per pair (sorted ids → rows t, score, combined, associated), as ``maritime.load`` reads a bag;
    ``fusion``: the fusion node's parameters (``fusion_of`` of the run's scenario file; ``fusion_config``)."""
    fa = PairAssociator(fusion_config(**fusion))
    tracks = dict(d['tracks'])
    tracks[mar.NETWORK_TRACK] = (np.array([r['t'] for r in rows]), np.array([r['mean'] for r in rows]),
                               np.array([r['cov'] for r in rows]))
    reports = sorted(((float(t), k, x, P) for k, (ts, xs, Ps) in tracks.items()
                      for t, x, P in zip(ts, xs, Ps, strict=True)), key=lambda r: r[0])
    out: dict[tuple[str, str], list] = {}
    for t, k, x, P in reports:
        for inst in fa.push(FUSION_SOURCE[k], k, TrackReport(t, x, P)):
            for p in inst.all_pairs():
                out.setdefault(tuple(sorted((p.a, p.b))), []).append((inst.t, p.score, p.combined, p.associated))
    return {pair: np.array(v, dtype=float) for pair, v in out.items()}


def summary(d: dict, rows: list[dict], scores: dict) -> dict:
    """RTAMS, true-pair fraction after convergence and decoy verdicts (``maritime.verdicts``) of a replay;
    belief NEES over the steps where it is defined, with the count (and the first) of those where not."""
    start = mar.run_start(d)
    d = {**d, 'tracks': {**d['tracks'], mar.NETWORK_TRACK: (np.array([r['t'] for r in rows]),
                                                          np.array([r['mean'] for r in rows]), None)},
         'scores': scores}
    err = mar.tracker_errors(d)
    v = mar.verdicts(d, err)
    pair = tuple(sorted((mar.SONAR_TRACK, mar.NETWORK_TRACK)))
    e = np.array([np.hypot(*(r['mean'] - r['truth'])) for r in rows])
    nees, why = belief_nees(rows)
    defined = np.isfinite(nees)
    first = int(np.flatnonzero(~defined)[0]) if (~defined).any() else None
    nb = np.array([r['bytes'] for r in rows])
    return {'rtams': float(np.sqrt(np.mean(err[mar.NETWORK_TRACK][1] ** 2))), 'fraction': v[pair]['fraction'],
            'instants': v[pair]['instants_after'],
            'decoy_ever': any(r['ever'] for p, r in v.items() if mar.RADAR_DECOY in p),
            'bytes_mean': float(nb.mean()), 'bytes_max': int(nb.max()), 'error_max': float(e.max()),
            'nees_mean': float(nees[defined].mean()) if defined.any() else float('nan'),
            'nees_over_6': float(np.mean(nees[defined] > 6.0)) if defined.any() else float('nan'),
            'nees_undefined': int((~defined).sum()),
            'nees_undefined_first': None if first is None else (float(rows[first]['t'] - start), why[first])}


def belief_nees(rows: list[dict]) -> tuple[np.ndarray, list[str | None]]:
    """(steps,) NEES of the belief (2 dof) and per step the reason it is NaN (None where defined)."""
    if not rows:
        return np.zeros(0), []
    return nees_or_nan(np.array([r['mean'] - r['truth'] for r in rows]), np.array([r['cov'] for r in rows]))


def trace_lines(rows: list[dict], scores: dict, start: float = 0.0) -> list[str]:
    """One line per step; times in s from ``start`` (the run's start)."""
    pair = {r[0]: r for r in scores.get(tuple(sorted((mar.SONAR_TRACK, mar.NETWORK_TRACK))), [])}
    nees, _ = belief_nees(rows)
    out = []
    for r, q in zip(rows, nees, strict=True):
        e = r['mean'] - r['truth']
        lo, hi = np.sqrt(np.clip(np.linalg.eigvalsh(r['cov']), 0.0, None))  # a collapsed belief: 0, not NaN
        f = pair.get(r['t'])
        nees_txt = f'NEES {q:5.1f}' if np.isfinite(q) else 'NEES  sing.'  # singular covariance: no NEES
        out.append(f"t={r['t'] - start:5.1f} leader {r['leader']:3d}{'D' if r['doa'] else 'A'} at {r['range']:5.1f} m  "
                   f"error {np.hypot(*e):5.1f} m  σ {hi:5.1f}/{lo:4.1f} m  {nees_txt}  "
                   f"{r['size']:5d} entries {r['bytes']:7d} B"
                   + (f"  score {f[1]:.2f} combined {f[2]:.2f} {'assoc.' if f[3] else '-'}" if f is not None else ''))
    return out


def _value(text: str):
    try:
        return float(text)
    except ValueError:
        return text


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(prog='python -m track_nodes.report.network_replay',
                                 description=__doc__.split('\n\n')[0])
    ap.add_argument('bag', type=Path)
    ap.add_argument('--scenario', type=Path, default=Path('config/maritime.yaml'), help='the run\'s scenario file')
    ap.add_argument('--set', action='append', default=[], metavar='KEY=VALUE', help='TrackerParams override')
    ap.add_argument('--comm-range', type=float, default=None, help='radio range [m] (default: the scenario\'s)')
    ap.add_argument('--trace', action='store_true', help='one line per instant')
    a = ap.parse_args(argv)
    over = {k: _value(v) for k, v in (kv.split('=', 1) for kv in a.set)}
    setup, layout = sensors_of(a.scenario, a.comm_range, **over)
    d = mar.load(a.bag)
    rows = replay(d, setup, layout)
    scores = fuse(d, rows, **fusion_of(a.scenario))
    start = mar.run_start(d)
    print(mar.start_note(start))
    if a.trace:
        print('\n'.join(trace_lines(rows, scores, start)))
    s = summary(d, rows, scores)
    print(f"network RTAMS {s['rtams']:.1f} m (max error {s['error_max']:.1f} m); true pair associated at "
          f"{100 * s['fraction']:.1f}% of {s['instants']} instants after both converged; decoy ever associated: "
          f"{s['decoy_ever']}; {s['bytes_mean']:.0f} B per handoff (max {s['bytes_max']}); belief NEES mean "
          f"{s['nees_mean']:.2f}, > 6 at {100 * s['nees_over_6']:.0f}% of the steps" + nees_note(s))


def nees_note(s: dict) -> str:
    """'' or why some steps have no NEES (a belief collapsed to one cell: singular covariance)."""
    if not s['nees_undefined']:
        return ''
    t, why = s['nees_undefined_first']
    return (f" with a defined NEES; undefined at {s['nees_undefined']} step(s), first at t={t:.1f} s ({why}): "
            'left out of the mean')


if __name__ == '__main__':
    main()

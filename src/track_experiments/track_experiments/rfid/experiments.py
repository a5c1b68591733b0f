"""``track-experiment`` entries ``rfid-table1`` (Table I) and ``rfid-reader`` (a commercial reader's phase stream).

``track-experiment rfid-table1``: Table I of the paper, the routes of Fig. 6, the obstacle variant.
Per N ∈ {10, 20, 50, 100, 300, 1000}: M searches (200 in the full run) from 10 m with the worst-case
errors (Section VI), the same M run seeds for every N; per N the means of steps, turns, distance
walked, update wall time and the success rate (a failed run counts ``max_steps``), the paper's
beside. Also ``rfid-fig6-route.png``, ``rfid-obstacles-route.png``, ``rfid-table1-obstacles.json``
and ``rfid-table1-variants.json`` (``suggestion='mean'``, no re-initialisation, ``init_boost`` 10).
``--json``: ``{"rows": [{particles, steps, turns, distance_m, update_ms, success_rate}]}``.

``track-experiment rfid-reader``: the reader signal processing and the filter on a commercial
reader's phase stream, in simulation; one ``SeedSequence`` per part and trial, from ``--seed``:
1. MOVE sweep: ``trials`` walks of ``MOVES_PER_TRIAL`` MOVEs of 0.5 m read by ``READER`` with the
   effects of each row (lasting steps, hopping over ``CHANNELS``, noise), processed five ways (ours,
   online, join, old, naive); share of MOVEs kept, |dφ − dφ_true| statistics, dphi_std coverage.
2. Sign convention and guidance: ``runs`` Table I searches with the paper's reader, an LLRP reader
   with its sign set, and the LLRP stream fed as-is.
3. Filter against the batch fit (``batch.fit_tag``): 5 straight MOVEs of 0.2 m past a tag beside the
   track, mirror-folded tag error, for Gaussian, 1/m² and fixed-s_θ weights.
4. Mirror sides: part 3's walk, a 60° TURN and 3 MOVEs; ``tag_sides`` after each part. ``--quick``:
   6 trials/searches/walks a part (full: 200, 200, 100, 100). ``--json``: ``{"moves": [...], "sign":
   {...}, "pf_batch": {...}, "sides": {...}}``. ``--set file=LOG.csv`` (``--set epc=EPC``): a
   recorded walk (``track_core.rfid.log``) instead of the simulation (``log_replay``). In full:
   docs/results/rfid.md, "What rfid-table1 and rfid-reader run".
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from track_core.rfid.batch import fit_tag, path_from_moves, tag_in_user_frame
from track_core.rfid.pf import PFParams, RfidParticleFilter
from track_core.rfid.phase import PhaseModel
from track_core.rfid.protocol import Command, CommandKind
from track_core.rfid.search import MAX_STEPS, SearchOutcome, run_search
from track_core.rfid.signal import PhaseProcessor, PhaseStream, UnwrapConfig, naive_dphi, process_move
from track_core.rfid.world import SimReader, WorldParams, office_obstacles
from track_experiments.cli import Outcome, RunConfig, format_table, set_keys
from track_experiments.plotting import pyplot

PARTICLES = (10, 20, 50, 100, 300, 1000)
# Table I: N → (STEPS, TURNS, DISTANCE m, TIME ms); the paper reports 100 % success everywhere.
PAPER_TABLE1 = {10: (30.0, 35.9, 15.4, 10.4), 20: (29.4, 35.0, 15.0, 11.8), 50: (29.2, 34.5, 15.0, 17.8),
                100: (28.5, 33.2, 14.6, 29.2), 300: (28.3, 33.0, 14.5, 90.7), 1000: (28.0, 32.2, 14.3, 473.9)}
BOOST = 10        # the variant with prior boosting (pf: init_boost) at small N


def run_batch(world: WorldParams, pf: PFParams, seeds: list[np.random.SeedSequence],
              max_steps: int = MAX_STEPS, progress=iter) -> list[SearchOutcome]:
    return [run_search(world, pf, np.random.default_rng(s), max_steps) for s in progress(seeds)]


def summarize(runs: list[SearchOutcome]) -> dict:
    """Means over all runs (failures included) and the success rate."""
    upd = [r.update_ms for r in runs if math.isfinite(r.update_ms)]
    return {'steps': float(np.mean([r.steps for r in runs])),
            'turns': float(np.mean([r.turns for r in runs])),
            'distance_m': float(np.mean([r.distance_m for r in runs])),
            'update_ms': float(np.mean(upd)) if upd else math.nan,
            'success_rate': float(np.mean([r.success for r in runs]))}


def table1(cfg: RunConfig) -> Outcome:
    n_runs = cfg.n_runs(full=200, quick=4)
    particles = PARTICLES
    world = WorldParams()
    seeds = np.random.SeedSequence(cfg.seed).spawn(n_runs)
    rows, table_rows, run0 = [], [], {}
    for n in particles:
        pf = PFParams(n_particles=n, beam_width=world.beam_width)
        runs = run_batch(world, pf, seeds, progress=lambda it, n=n: cfg.progress(it, desc=f'rfid N={n}',
                                                                                   total=n_runs))
        run0[n] = runs[0]
        row = {'particles': n, **summarize(runs)}
        rows.append(row)
        ps, pt, pd, pm = PAPER_TABLE1[n]
        table_rows.append([n, f"{row['steps']:.1f}", ps, f"{row['turns']:.1f}", pt, f"{row['distance_m']:.1f}", pd,
                           f"{row['update_ms']:.3f}", pm, f"{100 * row['success_rate']:.1f}", 100.0])
    table = (f'Table I, {n_runs} runs per N from {world.start_distance:g} m, worst-case errors '
             f'(means over all runs; failures count {MAX_STEPS} steps)\n'
             + format_table(['N', 'steps', 'paper', 'turns', 'paper', 'dist m', 'paper', 'update ms', 'paper',
                             'success %', 'paper'], table_rows))

    # obstacle variant at N = 100; the two additions switched off at N = 10 and 100
    pf100 = PFParams(n_particles=100, beam_width=world.beam_width)
    obs_world = replace(world, obstacles=office_obstacles())
    obs_runs = run_batch(obs_world, pf100, seeds, progress=lambda it: cfg.progress(it, desc='rfid obstacles',
                                                                                    total=n_runs))
    obs = {'particles': 100, 'runs': n_runs, **summarize(obs_runs)}
    variants = {}
    for n in (10, 100):
        base = replace(pf100, n_particles=n)
        for name, pf in ((f'N={n} paper circular mean (suggestion=mean)', replace(base, suggestion='mean')),
                         (f'N={n} no re-initialisation (reinit_factor=None)', replace(base, reinit_factor=None)),
                         *(((f'N={n} prior boosting (init_boost={BOOST})', replace(base, init_boost=BOOST)),)
                           if n == 10 else ())):
            variants[name] = {'particles': n, 'runs': n_runs,
                              **summarize(run_batch(world, pf, seeds, progress=lambda it, name=name: cfg.progress(
                                  it, desc=f'rfid {name[:16]}', total=n_runs)))}
    cfg.out.mkdir(parents=True, exist_ok=True)
    (cfg.out / 'rfid-table1-obstacles.json').write_text(json.dumps(obs, indent=2) + '\n')
    (cfg.out / 'rfid-table1-variants.json').write_text(json.dumps(variants, indent=2) + '\n')
    extra = [['N=100 obstacles (office_obstacles)', *_cells(obs)]] + [[k, *_cells(v)] for k, v in variants.items()]
    table += (f'\n\nVariants, {n_runs} runs, the same seeds\n'
              + format_table(['variant', 'steps', 'turns', 'dist m', 'update ms', 'success %'],
                             [['N=10 default (as Table I)', *_cells(rows[particles.index(10)])],
                              ['N=100 default (as Table I)', *_cells(rows[particles.index(100)])], *extra]))
    figs = [plot_route(run0[100], world, cfg.out / 'rfid-fig6-route.png',
                       'Fig. 6 analogue: route of run 0, N = 100'),
            plot_route(obs_runs[0], obs_world, cfg.out / 'rfid-obstacles-route.png',
                       'Obstacle variant: route of run 0, N = 100')]
    return Outcome(table, {'rows': rows}, figs)


def _cells(s: dict) -> list:
    return [f"{s['steps']:.1f}", f"{s['turns']:.1f}", f"{s['distance_m']:.1f}", f"{s['update_ms']:.3f}",
            f"{100 * s['success_rate']:.1f}"]


def plot_route(run: SearchOutcome, world: WorldParams, path: Path, title: str) -> Path:
    """Fig. 6 style: user positions '+' (black), start 'o' (green), tag '*' (red), obstacles grey."""
    plt = pyplot()
    from matplotlib.patches import Rectangle

    fig, ax = plt.subplots(figsize=(6, 6))
    for r in world.obstacles:
        ax.add_patch(Rectangle((r.xmin, r.ymin), r.xmax - r.xmin, r.ymax - r.ymin, color='0.7'))
    route = run.route
    ax.plot(route[:, 0], route[:, 1], '-', color='0.6', lw=0.8)
    ax.plot(route[:, 0], route[:, 1], 'k+', label='user after each step')
    ax.plot(route[0, 0], route[0, 1], 'go', mfc='none', ms=10, label='start')
    ax.plot(0.0, 0.0, 'r*', ms=12, label='RFID tag')
    pts = np.vstack([route, [[0.0, 0.0]], *[[[r.xmin, r.ymin], [r.xmax, r.ymax]] for r in world.obstacles]])
    (x0, y0), (x1, y1) = pts.min(0), pts.max(0)
    half = 0.5 * max(x1 - x0, y1 - y0) + 1.0
    cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
    ax.set_xlim(cx - half, cx + half)
    ax.set_ylim(cy - half, cy + half)
    ax.set_aspect('equal')
    ax.set_xlabel('x (m)')
    ax.set_ylabel('y (m)')
    status = 'found' if run.success else 'not found'
    ax.set_title(f'{title}\n{run.steps} steps, {run.turns} turns, {run.distance_m:.1f} m, {status}')
    ax.legend(loc='best', fontsize=8)
    ax.grid(True, lw=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


CHANNELS = tuple(920.625e6 + 0.5e6 * j for j in range(8))   # 920.625 MHz and 7 others, 0.5 MHz apart
READER = PhaseModel(carrier_hz=920.625e6, wrap_period=2.0 * math.pi, s_theta=0.015, convention='llrp')
MOVES_PER_TRIAL = 6
HEAVY_DOF, HEAVY_SCALE = 2.0, 0.03  # the heavy-tailed mode: t₂ read noise of scale 0.03 rad in 30 ms bursts
HEAVY_ROW = f'heavy tails (t{HEAVY_DOF:g}, {HEAVY_SCALE:g} rad)'
PF_PARTICLES = 20_000
PF_INIT_RANGE = (0.3, 5.0)          # prior distance: the read range of a bench set-up (m)
PF_INIT_BOOST = 10                  # the first update weighs 10·N prior samples (pf: init_boost)


# part 3: (name, f_w, the filter gets the reader's dφ std); the last one keeps the paper's s_θ = 5.5°
PF_VARIANTS = (('student_t', 'student_t', True), ('gaussian', 'gaussian', True),
               ('inverse_square', 'inverse_square', True),
               ('inverse_square, fixed s_θ 5.5°', 'inverse_square', False))
# part 3's real-reader modes on top of the hopping reader (WorldParams fields; 'phase': its s_θ)
PF_MODES = {'hop': {},
            'hop + heavy tails': {'phase': HEAVY_SCALE, 'noise_dof': HEAVY_DOF},
            'hop + heavy tails + steps': {'phase': HEAVY_SCALE, 'noise_dof': HEAVY_DOF, 'phase_step_rate': 1.0,
                                          'phase_step_size': (0.8, 2.5)}}


@dataclass(frozen=True)
class SweepRow:
    name: str
    world: WorldParams


def sweep_rows() -> list[SweepRow]:
    """The configurations of part 1 (module doc)."""
    base = WorldParams(phase=READER, beam_width=2.0 * math.pi)
    hop = {'channels_hz': CHANNELS}
    rows = [SweepRow('paper reader (eq. 3 sign, (0, π], 0.096 rad)', replace(base, phase=PhaseModel())),
            SweepRow('commercial reader, no effect', base)]
    rows += [SweepRow(f'steps {a:g} rad, 1/s', replace(base, phase_step_rate=1.0, phase_step_size=(a, a)))
             for a in (0.8, 1.5, 2.5)]
    rows += [SweepRow('steps 2.5 rad, 4/s', replace(base, phase_step_rate=4.0, phase_step_size=(2.5, 2.5)))]
    rows += [SweepRow(f'hop {d:g} s', replace(base, hop_dwell_s=d, **hop)) for d in (0.4, 0.2)]
    both = replace(base, hop_dwell_s=0.2, phase_step_rate=1.0, phase_step_size=(0.8, 2.5), **hop)
    rows += [SweepRow('hop 0.2 s + steps 0.8-2.5 rad 1/s', both),
             SweepRow('hop 0.2 s + steps 0.8-2.5 rad 1/s, (0, π]',
                      replace(both, phase=replace(READER, wrap_period=math.pi)))]
    rows += [SweepRow(f'hop 0.2 s, noise {s:g} rad', replace(base, hop_dwell_s=0.2, phase=replace(READER, s_theta=s),
                                                              **hop)) for s in (0.005, 0.05, 0.15)]
    heavy = replace(base, phase=replace(READER, s_theta=HEAVY_SCALE), noise_dof=HEAVY_DOF)
    rows += [SweepRow(HEAVY_ROW, heavy), SweepRow(f'{HEAVY_ROW} + hop 0.2 s', replace(heavy, hop_dwell_s=0.2, **hop)),
             SweepRow(f'{HEAVY_ROW} + hop 0.2 s + steps 0.8-2.5 rad 1/s',
                      replace(heavy, hop_dwell_s=0.2, phase_step_rate=1.0, phase_step_size=(0.8, 2.5), **hop))]
    return rows


def _fresh(ss: np.random.SeedSequence) -> np.random.SeedSequence:
    """A copy of ``ss`` that has spawned nothing yet: ``run_search`` spawns from its generator's seed
    sequence, which advances the original's counter, so reusing one object would not repeat a run."""
    return np.random.SeedSequence(ss.entropy, spawn_key=ss.spawn_key)


def _children(ss: np.random.SeedSequence, n: int) -> list[np.random.SeedSequence]:
    """What ``ss.spawn(n)`` gives the first time, without advancing ``ss``."""
    return _fresh(ss).spawn(n)


def _start(rng: np.random.Generator, lo: float, hi: float, psi: float) -> np.ndarray:
    d, th = rng.uniform(lo, hi), rng.uniform(-math.pi, math.pi)
    return np.array([d * math.cos(th), d * math.sin(th), th + math.pi + rng.uniform(-psi, psi)])


def move_trials(world: WorldParams, seeds: list[np.random.SeedSequence], moves: int = MOVES_PER_TRIAL) -> dict:
    """Part 1 for one configuration: per MOVE, the truth and the four methods' dφ (NaN: discarded)."""
    ph = world.phase
    ours_cfg = UnwrapConfig.real_reader(ph)
    join_cfg = replace(ours_cfg, step_bridge='join')
    old_cfg = UnwrapConfig.for_model(ph, relock_reads=0)
    online_cfg = replace(ours_cfg, noise='online')
    out = {k: [] for k in ('truth', 'ours', 'join', 'old', 'naive', 'online', 'relocks', 'hops', 'ours_std',
                           'online_std')}
    for ss in seeds:
        rng = np.random.default_rng(ss)
        start = _start(rng, 4.0, 10.0, math.radians(35.0))
        sim = SimReader(world, rng, start=start, unwrap=ours_cfg)
        join = PhaseProcessor(join_cfg)             # its own noise estimate, on the same streams
        online = PhaseProcessor(online_cfg)
        for j in range(moves):
            o = sim.execute(Command(CommandKind.MOVE, seq=j + 1))
            s = o.stream
            bare = PhaseStream(s.t, s.phase, s.rssi, s.t_start, s.t_end)
            out['truth'].append(o.truth_dphi)
            out['ours'].append(o.result.dphi)
            out['ours_std'].append(o.result.dphi_std)
            on = online.process(s)
            out['online'].append(on.dphi)
            out['online_std'].append(on.dphi_std)
            out['join'].append(join.process(s).dphi)
            out['old'].append(process_move(bare, old_cfg).dphi)
            out['naive'].append(naive_dphi(s, ours_cfg))
            out['relocks'].append(o.result.relocks)
            out['hops'].append(o.estimate.hops if o.estimate is not None else 0)
    return {k: np.array(v, dtype=float) for k, v in out.items()}


def _err_stats(x: np.ndarray, truth: np.ndarray, mask: np.ndarray | None = None) -> dict:
    ok = np.isfinite(x) if mask is None else mask & np.isfinite(x)
    e = np.abs(x[ok] - truth[ok])
    if e.size == 0:
        return {'kept': float(np.isfinite(x).mean()), 'median': math.nan, 'p95': math.nan, 'rms': math.nan}
    return {'kept': float(np.isfinite(x).mean()), 'median': float(np.median(e)),
            'p95': float(np.percentile(e, 95)), 'rms': float(np.sqrt(np.mean(e * e)))}


def coverage90(x: np.ndarray, std: np.ndarray, truth: np.ndarray, z: float = 1.645) -> float:
    """Share of the kept MOVEs whose |dφ error| is within ±z·dphi_std (z 1.645: the 90 % interval of a Gaussian;
    1: 68.3 %, 2: 95.4 %)."""
    ok = np.isfinite(x) & np.isfinite(std)
    return float(np.mean(np.abs(x[ok] - truth[ok]) <= z * std[ok])) if ok.any() else math.nan


def summarize_moves(r: dict) -> dict:
    t = r['truth']
    kept = np.isfinite(r['ours'])
    return {'moves': int(t.size), 'relocks_per_move': float(np.mean(r['relocks'])),
            'hops_per_move': float(np.mean(r['hops'])),
            **{m: _err_stats(r[m], t) for m in ('ours', 'join', 'old', 'naive', 'online')},
            'naive_on_ours_kept': _err_stats(r['naive'], t, kept),
            'ours_cov90': coverage90(r['ours'], r['ours_std'], t),
            'ours_cov1s': coverage90(r['ours'], r['ours_std'], t, 1.0),
            'ours_cov2s': coverage90(r['ours'], r['ours_std'], t, 2.0),
            'online_cov90': coverage90(r['online'], r['online_std'], t)}


def sign_runs(seeds: list[np.random.SeedSequence], n_particles: int = 100) -> dict:
    """Part 2: (success rate, mean steps) for the paper's reader, an LLRP reader with its sign, and fed as-is."""
    paper = WorldParams()
    llrp = replace(paper, phase=replace(paper.phase, convention='llrp'))
    pf = PFParams(n_particles=n_particles, beam_width=paper.beam_width)
    variants = {'paper reader': (paper, None), 'LLRP reader, sign set': (llrp, None),
                'LLRP reader fed as-is': (llrp, UnwrapConfig.for_model(paper.phase))}
    out = {}
    for name, (world, unwrap) in variants.items():
        runs = [run_search(world, pf, np.random.default_rng(_fresh(s)), unwrap=unwrap) for s in seeds]
        out[name] = {'runs': len(runs), 'success_rate': float(np.mean([r.success for r in runs])),
                     'steps': float(np.mean([r.steps for r in runs])),
                     'sign_warned': float(np.mean([bool(r.sign_warning) for r in runs]))}
    return out


def pf_batch_trial(ss: np.random.SeedSequence, n_particles: int = PF_PARTICLES, weighting: str = 'student_t',
                   n_moves: int = 5, step: float = 0.2, s_r: float = 0.002, s_a: float = math.radians(0.5),
                   reader: PhaseModel = READER, hop_dwell_s: float = 0.2,
                   init_range: tuple[float, float] = PF_INIT_RANGE, reader_noise: bool = True, mode: str = 'hop'
                   ) -> tuple[float, float, bool] | None:
    """Part 3, one walk: (filter error, batch error, filter says bimodal), errors mirror-folded (m).

    The tag is beside the track, as in a bench set-up: 0.5–2 m to the left or right of the walking
    line, 0–1.5 m along it from the start (so it is in front at the start). ``mode`` adds the
    real-reader effects of ``PF_MODES`` to the hopping reader. A MOVE the reader could not measure
    costs that step: the filter only moves its particles (``predict``) and the batch fit leaves its
    term out. None when fewer than 2 MOVEs were usable.
    """
    rw, rp = (np.random.default_rng(s) for s in _children(ss, 2))
    along, side = rw.uniform(0.0, 1.5), rw.uniform(0.5, 2.0) * rw.choice([-1.0, 1.0])
    start = np.array([-along, -side, 0.0])            # the tag at the origin, the user walking along +x
    world = WorldParams(phase=reader, s_step=step, s_r=s_r, s_a=s_a, beam_width=2.0 * math.pi,
                        channels_hz=CHANNELS if hop_dwell_s > 0 else (), hop_dwell_s=hop_dwell_s)
    world = replace(world, **{k: (replace(reader, s_theta=v) if k == 'phase' else v)
                              for k, v in PF_MODES[mode].items()})
    sim = SimReader(world, rw, start=start, unwrap=UnwrapConfig.real_reader(reader))
    pf_phase = reader if reader_noise else replace(reader, s_theta=PhaseModel().s_theta)
    pf = RfidParticleFilter(PFParams(n_particles=n_particles, s_step=step, s_r=s_r, s_a=s_a, weighting=weighting,
                                     reinit_factor=None, init_range=init_range, init_boost=PF_INIT_BOOST),
                            pf_phase, rp)
    dphi = []
    for j in range(n_moves):
        res = sim.execute(Command(CommandKind.MOVE, seq=j + 1)).result
        if not res.ok:                # the walk goes on: this step moves the particles, weighs nothing
            dphi.append(math.nan)
            pf.predict(0.0)
            continue
        dphi.append(res.dphi)
        pf.update(res.dphi, 0.0, dphi_std=res.dphi_std if reader_noise else None)
    if np.isfinite(dphi).sum() < 2:
        return None
    x, y, a = sim.pose
    truth = tag_in_user_frame(np.zeros(2), np.array([x, y]), a)
    est = pf.tag_posterior()
    pos, head = path_from_moves(np.full(n_moves, step), np.zeros(n_moves))
    fit = fit_tag(pos, np.array(dphi), reader.k)
    b = tag_in_user_frame(fit.xy, pos[-1], float(head[-1]))

    def folded(v: np.ndarray) -> float:
        return min(math.hypot(v[0] - truth[0], v[1] - truth[1]), math.hypot(v[0] - truth[0], -v[1] - truth[1]))

    return folded(np.array([est.x, est.y])), folded(b), est.bimodal


def pf_batch(seeds: list[np.random.SeedSequence], n_particles: int = PF_PARTICLES, modes=tuple(PF_MODES),
             variants=PF_VARIANTS) -> dict:
    """Part 3: per mode and filter variant, the medians over the walks (the same walks for every variant)."""
    out = {}
    for mode in modes:
        for name, weighting, reader_noise in variants:
            r = [pf_batch_trial(s, n_particles, weighting, reader_noise=reader_noise, mode=mode) for s in seeds]
            r = np.array([x for x in r if x is not None], dtype=float).reshape(-1, 3)
            out[f'{mode}: {name}'] = {
                'mode': mode, 'weighting': name, 'trials': int(r.shape[0]), 'particles': n_particles,
                'pf_median_m': float(np.median(r[:, 0])), 'batch_median_m': float(np.median(r[:, 1])),
                'ratio': float(np.median(r[:, 0]) / np.median(r[:, 1])), 'bimodal_rate': float(np.mean(r[:, 2]))}
    return out


SIDE_TURN_DEG = 60.0                # part 4: the turn off the walking line after the straight part


def side_trial(ss: np.random.SeedSequence, n_particles: int = PF_PARTICLES, turn_deg: float = SIDE_TURN_DEG,
               after: int = 3) -> dict:
    """Part 4, one walk: part 3's straight walk (hopping reader, Student-t weights), then a TURN of ``turn_deg``
    and ``after`` MOVEs. After each part, from ``RfidParticleFilter.tag_sides``: whether the side is reported
    unknown, the true side's probability, the error of the true side's mode and of the likelier mode (m, not
    folded: what a guidance that gives one point would be off by)."""
    rw, rp = (np.random.default_rng(s) for s in _children(ss, 2))
    along, side = rw.uniform(0.0, 1.5), rw.uniform(0.5, 2.0) * rw.choice([-1.0, 1.0])
    world = WorldParams(phase=READER, s_step=0.2, s_r=0.002, s_a=math.radians(0.5), beam_width=2.0 * math.pi,
                        channels_hz=CHANNELS, hop_dwell_s=0.2)
    sim = SimReader(world, rw, start=np.array([-along, -side, 0.0]), unwrap=UnwrapConfig.real_reader(READER))
    pf = RfidParticleFilter(PFParams(n_particles=n_particles, s_step=0.2, s_r=0.002, s_a=math.radians(0.5),
                                     weighting='student_t', reinit_factor=None, init_range=PF_INIT_RANGE,
                                     init_boost=PF_INIT_BOOST), READER, rp)
    seq = iter(range(1, 1000))

    def move(turn: float) -> None:
        res = sim.execute(Command(CommandKind.MOVE, seq=next(seq))).result
        if res.ok:
            pf.update(res.dphi, turn, dphi_std=res.dphi_std)
        else:
            pf.predict(turn)

    def report(prefix: str) -> dict:
        x, y, a = sim.pose
        tx, ty = tag_in_user_frame(np.zeros(2), np.array([x, y]), a)
        s = pf.tag_sides()
        true, best = (s.left if ty > 0 else s.right), s.likelier
        return {f'{prefix}_unknown': float(s.unknown), f'{prefix}_p_true': true.probability,
                f'{prefix}_true_mode_m': math.hypot(true.x - tx, true.y - ty),
                f'{prefix}_likelier_m': math.hypot(best.x - tx, best.y - ty)}

    for _ in range(5):
        move(0.0)
    out = report('straight')
    move(sim.execute(Command(CommandKind.TURN, math.radians(turn_deg), seq=next(seq))).result.turn)
    for _ in range(after - 1):
        move(0.0)
    return {**out, **report('turned')}


def side_runs(seeds: list[np.random.SeedSequence], n_particles: int = PF_PARTICLES) -> dict:
    """Part 4 over the walks: shares and medians (``side_trial``)."""
    r = [side_trial(s, n_particles) for s in seeds]
    out = {'walks': len(r), 'particles': n_particles, 'turn_deg': SIDE_TURN_DEG}
    for part in ('straight', 'turned'):
        p = np.array([x[f'{part}_p_true'] for x in r])
        out[part] = {'unknown_rate': float(np.mean([x[f'{part}_unknown'] for x in r])),
                     'p_true_median': float(np.median(p)), 'p_true_above_0.9': float(np.mean(p > 0.9)),
                     'true_mode_median_m': float(np.median([x[f'{part}_true_mode_m'] for x in r])),
                     'likelier_median_m': float(np.median([x[f'{part}_likelier_m'] for x in r]))}
    return out


@set_keys(file='a reader log (CSV, track_core.rfid.log) processed instead of the simulation (none)',
          epc='the tag of the log to use (the log\'s own # epc:, or its only tag)')
def reader_experiment(cfg: RunConfig) -> Outcome:
    if 'file' in cfg.options:      # a recorded walk instead of the simulation (rfid/log_replay.py)
        from track_experiments.rfid.log_replay import log_experiment

        return log_experiment(cfg)
    if 'epc' in cfg.options:
        raise ValueError('--set epc needs --set file=LOG.csv (the simulation has one tag)')
    n_trials = cfg.n_runs(full=200, quick=6)
    n_search = cfg.n_runs(full=200, quick=6)
    n_pf = cfg.n_runs(full=100, quick=6)
    ss_moves, ss_sign, ss_pf = np.random.SeedSequence(cfg.seed).spawn(3)
    move_seeds = ss_moves.spawn(n_trials)
    moves, rows = [], []
    for row in cfg.progress(sweep_rows(), desc='rfid-reader moves'):
        s = {'config': row.name, **summarize_moves(move_trials(row.world, move_seeds))}
        moves.append(s)
        o, j, od, nv, on = s['ours'], s['join'], s['old'], s['naive_on_ours_kept'], s['online']
        rows.append([row.name, f"{100 * o['kept']:.1f}", f"{100 * on['kept']:.1f}", f"{100 * od['kept']:.1f}",
                     f"{o['median']:.3f}", f"{o['rms']:.3f}", f"{100 * s['ours_cov1s']:.1f}",
                     f"{100 * s['ours_cov2s']:.1f}", f"{100 * s['ours_cov90']:.1f}",
                     f"{100 * s['online_cov90']:.1f}", f"{nv['median']:.3f}", f"{nv['rms']:.3f}", f"{j['median']:.3f}",
                     f"{j['rms']:.3f}", f"{od['median']:.3f}", f"{s['relocks_per_move']:.2f}"])
    table = (f'MOVEs ({n_trials} walks x {MOVES_PER_TRIAL} MOVEs of 0.5 m per row); |dφ error| in rad, median and '
             'RMS over the MOVEs kept; naive on the MOVEs ours kept; cov 1σ, 2σ, 90: share of kept MOVEs within '
             '±1, ±2, ±1.645 dphi_std\n'
             + format_table(['config', 'kept %', 'online kept %', 'old kept %', 'ours med', 'ours rms', 'cov 1σ %',
                             'cov 2σ %', 'cov90 %',
                             'online cov90 %', 'naive med', 'naive rms', 'join med', 'join rms', 'old med',
                             'relocks/move'], rows))
    sign = sign_runs(ss_sign.spawn(n_search))
    table += (f'\n\nGuidance, Table I setting, N = 100, {n_search} searches each (same seeds)\n'
              + format_table(['reader', 'success %', 'steps', 'convention warned %'],
                             [[k, f"{100 * v['success_rate']:.1f}", f"{v['steps']:.1f}",
                               f"{100 * v['sign_warned']:.1f}"] for k, v in sign.items()]))
    pfb = pf_batch(ss_pf.spawn(n_pf))
    table += (f'\n\nTag error after 5 MOVEs of 0.2 m (hopping reader, small motion errors), median over the walks, '
              f'mirror folded; filter N = {PF_PARTICLES}\n'
              + format_table(['mode: filter weights', 'walks', 'filter m', 'batch LS m', 'ratio', 'bimodal %'],
                             [[k, v['trials'], f"{v['pf_median_m']:.3f}", f"{v['batch_median_m']:.3f}",
                               f"{v['ratio']:.2f}", f"{100 * v['bimodal_rate']:.0f}"] for k, v in pfb.items()]))
    sides = side_runs(_children(ss_pf, 2)[1].spawn(n_pf))
    table += (f'\n\nMirror sides: part 3\'s straight walk, then a TURN of {SIDE_TURN_DEG:g}° and 3 MOVEs; '
              f'{sides["walks"]} walks, N = {PF_PARTICLES}; errors not folded (m, median)\n'
              + format_table(['after', 'side unknown %', 'p(true side) median', 'p(true side) > 0.9 %',
                              'true side mode m', 'likelier mode m'],
                             [[k, f"{100 * v['unknown_rate']:.0f}", f"{v['p_true_median']:.2f}",
                               f"{100 * v['p_true_above_0.9']:.0f}", f"{v['true_mode_median_m']:.3f}",
                               f"{v['likelier_median_m']:.3f}"]
                              for k, v in ((k, sides[k]) for k in ('straight', 'turned'))]))
    return Outcome(table, {'moves': moves, 'sign': sign, 'pf_batch': pfb, 'sides': sides}, [])

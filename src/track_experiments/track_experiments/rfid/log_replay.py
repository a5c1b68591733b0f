"""``track-experiment rfid-reader --set file=LOG.csv``: the reader experiment on a recorded walk.

The log (layout: ``track_core.rfid.log``) replaces the simulation. Its MOVEs are processed four ways,
as in part 1 of ``rfid-reader`` (*ours*: ``UnwrapConfig.real_reader``, learning its noise over the
log's MOVEs; *join*; *old*: no re-lock, fixed noise, carriers ignored; *naive*: ``np.unwrap``), and the
MOVEs feed the filter and ``batch.fit_tag`` as in part 3 (the filter with part 3's settings: its
motion errors s_r 2 mm and s_a 0.5°, Student-t weights, the reader's dφ std, init_boost 10; the batch on
the commanded path: the logged step lengths and turns). A MOVE ours cannot use still moved the user (a
logged walk is not undone): the filter only moves its particles (``predict``) and the batch leaves its
term out, so it costs that step, not the walk. With truth in the log (our simulator writes it), every
dφ is compared with the geometric one and the tag errors are given (mirror folded, in the final user
frame); without it the estimates only.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from track_core.rfid.batch import fit_tag, path_from_moves, tag_in_user_frame
from track_core.rfid.log import read_log
from track_core.rfid.pf import PFParams, RfidParticleFilter
from track_core.rfid.protocol import CommandKind
from track_core.rfid.signal import PhaseProcessor, PhaseStream, UnwrapConfig, naive_dphi, process_move
from track_experiments.cli import Outcome, RunConfig, format_table

METHODS = ('ours', 'join', 'old', 'naive')


def _folded(v: np.ndarray, truth: np.ndarray) -> float:
    return min(math.hypot(v[0] - truth[0], v[1] - truth[1]), math.hypot(v[0] - truth[0], -v[1] - truth[1]))


def log_experiment(cfg: RunConfig, particles: int = 20_000, init_range: tuple[float, float] = (0.3, 5.0)) -> Outcome:
    log = read_log(cfg.options['file'], epc=cfg.options.get('epc') or None)
    ph = log.phase_model()
    ours = PhaseProcessor(UnwrapConfig.real_reader(ph))
    join = PhaseProcessor(replace(ours.cfg, step_bridge='join'))
    old_cfg = UnwrapConfig.for_model(ph, relock_reads=0)
    rows, moves = [], []
    turn, turns, steps, dphi = 0.0, [], [], []
    rng = np.random.default_rng(np.random.SeedSequence(cfg.seed))
    lengths = [a.value for a in log.moves if math.isfinite(a.value)]
    step = float(np.median(lengths)) if lengths else 0.5
    pf = RfidParticleFilter(PFParams(n_particles=particles, s_step=step, s_r=0.002, s_a=math.radians(0.5),
                                     weighting='student_t', reinit_factor=None, init_range=init_range,
                                     init_boost=10), ph, rng)
    for a in log.actions:
        if a.kind is CommandKind.TURN:
            turn += a.value
            continue
        s = a.stream
        est = ours.process(s)
        r = {'seq': a.seq, 'line': a.line, 'reads': len(s), 'truth': a.truth_dphi(ph.k), 'ours': est.dphi,
             'join': join.process(s).dphi, 'old': process_move(PhaseStream(s.t, s.phase, s.rssi, s.t_start, s.t_end),
                                                               old_cfg).dphi,
             'naive': naive_dphi(s, ours.cfg), 'dphi_std': est.dphi_std, 'reason': est.reason}
        moves.append(r)
        rows.append([a.seq, a.line, len(s), *(f'{r[m]:+.3f}' if math.isfinite(r[m]) else '-' for m in
                                               ('truth', *METHODS)), est.reason or 'ok'])
        if est.ok:
            pf.update(est.dphi, turn, dphi_std=est.dphi_std)
        else:                         # an unmeasured MOVE still moves the user: it costs this step only
            pf.predict(turn)
        turns.append(turn)
        steps.append(a.value if math.isfinite(a.value) else step)
        dphi.append(est.dphi)
        turn = 0.0
    table = (log.describe() + '\nMOVEs: dφ (rad, eq. 6 sign) from the truth and four processings\n'
             + format_table(['seq', 'line', 'reads', 'truth', *METHODS, 'ours says'], rows))
    kept = {m: float(np.mean([math.isfinite(r[m]) for r in moves])) if moves else math.nan for m in METHODS}
    err = {m: float(np.median([abs(r[m] - r['truth']) for r in moves if math.isfinite(r[m])]))
           if log.has_truth and any(math.isfinite(r[m]) for r in moves) else math.nan for m in METHODS}
    table += '\n\n' + format_table(['method', 'kept %', 'median |dφ error| rad'],
                                   [[m, f'{100 * kept[m]:.1f}', f'{err[m]:.3f}'] for m in METHODS])
    pfb = None
    if np.isfinite(dphi).sum() >= 2:
        est = pf.tag_posterior()
        pos, head = path_from_moves(np.array(steps), np.array(turns))
        fit = fit_tag(pos, np.array(dphi), ph.k)
        b = tag_in_user_frame(fit.xy, pos[-1], float(head[-1]))
        pfb = {'moves': len(dphi), 'usable': int(np.isfinite(dphi).sum()), 'particles': particles,
               'pf_xy': [est.x, est.y], 'batch_xy': [float(b[0]), float(b[1])], 'pf_error_m': math.nan,
               'batch_error_m': math.nan}
        last = log.actions[-1].pose
        if log.has_truth and last is not None:
            truth = tag_in_user_frame(np.zeros(2), last[:2], float(last[2]))
            pfb['pf_error_m'] = _folded(np.array([est.x, est.y]), truth)
            pfb['batch_error_m'] = _folded(b, truth)
        table += (f'\n\nTag in the final user frame (x forward, y left) from {int(np.isfinite(dphi).sum())} of '
                  f'{len(dphi)} MOVEs usable; filter N = '
                  f'{particles}\n' + format_table(['estimator', 'x m', 'y m', 'error m (mirror folded)'], [
                      ['filter', f'{est.x:.3f}', f'{est.y:.3f}', f"{pfb['pf_error_m']:.3f}"],
                      ['batch LS', f'{b[0]:.3f}', f'{b[1]:.3f}', f"{pfb['batch_error_m']:.3f}"]]))
    data = {'log': {'file': str(cfg.options['file']), 'epc': log.epc, 'reads': log.n_reads,
                    'other_reads': log.other_reads, 'moves': len(moves), 'truth': log.has_truth},
            'moves': moves, 'kept': kept, 'median_error': err, 'pf_batch': pfb}
    return Outcome(table, data, [])

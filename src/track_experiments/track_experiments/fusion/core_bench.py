"""``track-bench fusion-core``: the fusion core's CPU per tick against the track count, and its growth slope.

The core (``PairAssociator`` of ``CONFIG``: the node's defaults, exact score, gated, geometric mean, with
window 10 and reports stale after 2.5 s) is fed one report per track per tick (1 s) and scores each tick;
``tick_s`` is the median CPU time (``time.process_time``) of ``score`` over the measured ticks, after
``window`` warm-up ticks (full windows). Layouts:

- ``sea`` (``track_experiments.fusion.sea.SyntheticSea``): a constant ship density, the picture a
  larger sea gives. ``slope`` is the least-squares slope of log tick_s against log n over its
  sizes from 1000 up (goal ≤ 1.2: a tick costs O(n log n + candidates));
- ``solent`` (``bench.solent_layout``, needs the Solent data): 84 minutes of reports stacked into
  one picture, so the candidates grow as n² (the pessimistic case).

Identity: at the sizes up to ``REFERENCE_MAX`` tracks (``--quick``: ``REFERENCE_QUICK``) the same
reports also go, every tick, to a reference that scores every pair of different sources with the
exact score and keeps a window for every pair (``gate=False``: the brute force). ``max_abs_diff``
is the largest difference of any pair's instant score, combined score or window length over every
tick, ``verdicts_equal`` whether every association agrees (must be 0 and true), and
``reference_tick_s`` the brute force's CPU per tick.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from track_core.fusion import AssociatorConfig, PairAssociator, TrackReport
from track_experiments.cli import Outcome, RunConfig, format_table
from track_experiments.fusion.sea import SyntheticSea

WINDOW = 10
CONFIG = AssociatorConfig(window=WINDOW, stale_after=2.5)
REFERENCE_MAX, REFERENCE_QUICK = 1000, 300
SEA_SIZES, SEA_QUICK = (1000, 2000, 5000, 10_000), (300, 1000)
SOLENT_SIZES, SOLENT_QUICK = (100, 300, 1000, 3000), (300,)


class _Solent:
    """The stacked Solent picture: fixed tracks, each reporting around its position every tick."""

    def __init__(self, n: int, rng: np.random.Generator) -> None:
        from track_experiments.fusion.bench import solent_layout

        self.rng = rng
        self.mu, self.R = solent_layout(n, rng)
        self._L = np.linalg.cholesky(self.R)
        half = n // 2
        self.ids = [f'r{k:05d}' for k in range(half)] + [f'p{k:05d}' for k in range(n - half)]
        self.sources = ['/radar'] * half + ['/patrol'] * (n - half)

    def step(self, dt: float) -> tuple[np.ndarray, np.ndarray]:
        return self.mu + np.einsum('nij,nj->ni', self._L, self.rng.standard_normal(self.mu.shape)), self.R


def _core(gate: bool) -> PairAssociator:
    return PairAssociator(dataclasses.replace(CONFIG, gate=gate))


def _rows(inst) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(keys (a, b) as strings, values (score, combined, instants), verdicts) of every pair, sorted."""
    pairs = inst.all_pairs()
    keys = np.array([f'{inst.ids[a]}|{inst.ids[b]}' for a, b in zip(pairs.ia, pairs.ib, strict=True)])
    order = np.argsort(keys)
    vals = np.stack([pairs.score, pairs.combined, pairs.instants.astype(float)], 1)
    return keys[order], vals[order], pairs.associated[order]


def run_layout(layout, ticks: int, reference: bool) -> dict:
    """Feed ``layout`` to the gated core (and the brute force when ``reference``) for ``ticks`` ticks."""
    core, ref = _core(True), (_core(False) if reference else None)
    n = len(layout.ids)
    tick_s, ref_s, update_s, diff, same = [], [], [], 0.0, True
    for k in range(ticks):
        mu, R = layout.step(1.0)
        t = float(k)
        c0 = time.process_time()
        for i in range(n):
            core.update(layout.sources[i], layout.ids[i], TrackReport(t, mu[i], R[i]))
        c1 = time.process_time()
        inst = core.score(t)
        c2 = time.process_time()
        update_s.append(c1 - c0)
        tick_s.append(c2 - c1)
        if ref is not None:
            for i in range(n):
                ref.update(layout.sources[i], layout.ids[i], TrackReport(t, mu[i], R[i]))
            c3 = time.process_time()
            want = ref.score(t)
            ref_s.append(time.process_time() - c3)
            (ka, va, aa), (kb, vb, ab) = _rows(inst), _rows(want)
            if ka.shape != kb.shape or np.any(ka != kb):
                raise AssertionError(f'{n} tracks, tick {k}: the gated core listed other pairs than the reference')
            diff = max(diff, float(np.max(np.abs(va - vb), initial=0.0)))
            same &= bool(np.array_equal(aa, ab))
    measured = slice(WINDOW, None) if ticks > WINDOW else slice(ticks // 2, None)
    row = {'tracks': n, 'live_tracks': len(inst.ids), 'candidates': len(inst.pairs),
           'positive_pairs': int(np.sum(inst.pairs.score > 0)), 'associated': int(inst.pairs.associated.sum()),
           'tick_s': float(np.median(tick_s[measured])), 'update_s': float(np.median(update_s[measured])),
           'ticks': ticks}
    if ref is not None:
        row.update(reference_tick_s=float(np.median(ref_s[measured])), max_abs_diff=diff, verdicts_equal=same)
    return row


def slope(rows: list[dict], n_min: int = 1000) -> float | None:
    """Least-squares slope of log tick_s against log tracks over the rows with ≥ ``n_min`` tracks."""
    pts = [(np.log(r['tracks']), np.log(r['tick_s'])) for r in rows if r['tracks'] >= n_min]
    if len(pts) < 2:
        return None
    x, y = np.array(pts).T
    return float(np.polyfit(x, y, 1)[0])


def bench(cfg: RunConfig) -> Outcome:
    rng = np.random.default_rng(cfg.seed)
    ticks = cfg.n_runs(full=WINDOW + 5, quick=WINDOW + 2)
    out: dict = {'window': CONFIG.window, 'method': CONFIG.method}
    lines = []
    for name, sizes, make in (('sea', SEA_QUICK if cfg.quick else SEA_SIZES, SyntheticSea),
                              ('solent', SOLENT_QUICK if cfg.quick else SOLENT_SIZES, _Solent)):
        try:
            ref_max = REFERENCE_QUICK if cfg.quick else REFERENCE_MAX
            rows = [dict(layout=name, **run_layout(make(n, rng), ticks, n <= ref_max)) for n in sizes]
        except OSError as exc:    # the Solent data are not here
            out[name] = {'skipped': str(exc)}
            continue
        out[name] = {'rows': rows, 'slope': slope(rows, 1000 if not cfg.quick else 300)}
        lines += rows
    table = format_table(['layout', 'tracks', 'candidates', 'score > 0', 'associated', 'tick CPU s',
                          'updates CPU s', 'brute force s', 'max |diff|', 'verdicts'],
                         [[r['layout'], r['tracks'], r['candidates'], r['positive_pairs'], r['associated'],
                           r['tick_s'], r['update_s'], r.get('reference_tick_s', '-'), r.get('max_abs_diff', '-'),
                           ('equal' if r['verdicts_equal'] else 'DIFFER') if 'verdicts_equal' in r else '-']
                          for r in lines])
    for name in ('sea', 'solent'):
        if 'slope' in out[name] and out[name]['slope'] is not None:
            table += f'\n{name}: log-log slope of tick CPU against tracks = {out[name]["slope"]:.2f}'
        elif 'skipped' in out[name]:
            table += f'\n{name}: skipped ({out[name]["skipped"]})'
    table += (f'\nexact score, gated, window {WINDOW}; median CPU of score() per tick after {WINDOW} warm-up ticks; '
              'brute force = every pair scored, a window per pair (same reports, same run)')
    return Outcome(table, out)

"""``track-experiment ais-association``: same-ship decisions between two simulated sources on real AIS ships.

The Solent AIS reports (:mod:`.reader`, bad rows skipped and counted) are the truth. A coastal radar
and a patrol aircraft (:mod:`.sources`, :data:`~.sources.RADAR`, :data:`~.sources.PATROL`) observe
the ships, each under its own local track ids. For each score method (``exact``, ``glr``,
``glr_thresholded``, ``mc`` with N = 500), every cross-source pair of local tracks is scored at
every common instant (one batched ``score`` call per method); a pair is associated at an instant
when its score is ≥ 0.5, declared the same ship when associated at at least half of its common
instants, and the declared pairs are made one-to-one (Hungarian); precision, recall and F1 are
computed against the MMSI (:mod:`.association` has the rule and the reasons). Also reported: pair
evaluations (the paper's benchmark: 100,000 per hour), the decisions before one-to-one, a
decision-rule ablation, a threshold sweep and a noise sweep (both sources' ellipses scaled by k, the
same noise draws).

``--runs R`` pools R realisations of the sources' noise (default 3; ``--quick``: 1 run on the first
15 minutes, noise scales 1 and 4). ``--json`` writes ``{"ships", "pairs_scored", "methods": {method:
{"precision", "recall", "f1", ...}}, "noise_sweep", "rule_ablation", "short_pair_rule",
"threshold_sweep", "rows_skipped", "skipped", "warnings", "derived_defaults", "peak_rss_mb",
"chunks", ...}``; PNGs: ``ais-association.png`` (map, wrong pairs in red, a zoom on the densest 4
km) and ``ais-noise-sweep.png``.

Any AIS file (``--set KEY=VALUE``): ``file``, ``columns`` (a preset or ``"time=...;mmsi=...;lat=...;
lon=...[;cog=;sog=;time_format=...]"``), ``max_distance_km`` (``auto`` | ``off`` | km), ``max_gap``
(``auto`` | s), ``radar_site`` (``hull:<bearing>`` | ``origin`` | ``lat,lon``), ``duration`` (s),
``sweep`` (noise scales), ``prior_weight`` (ν of the short-pair rule, 0: plain majority),
``max_pairs`` (pair-instants per scored chunk, 1,000,000; folded into
:class:`~.association.StreamingDecisions`). Defaults derived from the data are printed and written
under ``derived_defaults``; reader rules dropping over 2 % of the rows are ``warnings``. Results
(Solent and a synthetic sea): docs/results/fusion.md, "AIS association".
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from track_core.ais.association import (
    SHORT_PAIR_RATE,
    SHORT_PAIR_WEIGHT,
    Metrics,
    PairDecisions,
    StreamingDecisions,
    evaluate,
    evaluate_mmsi,
    pair_tables,
)
from track_core.ais.reader import AisData, read_ais
from track_core.ais.sources import (
    PATROL,
    RADAR,
    ShipTruth,
    SourceModel,
    SourceReports,
    resolve_site,
    simulate_source,
)
from track_core.geofeasibility.scores import METHODS
from track_core.geofeasibility.track import THRESHOLD
from track_experiments.cli import Outcome, RunConfig, format_table, set_keys, unknown_keys_problem
from track_experiments.plotting import pyplot

PAPER_EVALS_PER_HOUR = 100_000
#: The ``--set`` keys (module docstring): key → what it sets.
OPTIONS = {
    'file': 'path of an AIS CSV export (default: the Solent file of the data folder)',
    'columns': ('the column mapping: a preset (solent, marinecadastre, dma) or "time=NAME;mmsi=NAME;lat=NAME;'
                'lon=NAME[;cog=NAME;sog=NAME;time_format=auto|iso|epoch_ms|epoch_s|strptime;delimiter=,]" '
                '(an empty value means absent: cog=;sog= computes them from positions; default: the preset '
                'the header matches)'),
    'max_distance_km': 'region kept around the median position: auto (derived from the data), off, or km (auto)',
    'max_gap': 'longest gap [s] a ship track is interpolated over: auto (per ship) or s (auto)',
    'radar_site': 'coastal radar site: hull:<bearing deg> (edge of the traffic), origin, or lat,lon (hull:280)',
    'duration': 's of data used from the start (the whole file; --quick: 900)',
    'sweep': 'noise scales k of the noise sweep, comma-separated (0.5,1,2,4,8; --quick: 1,4)',
    'prior_weight': 'ν of the short-pair rule; 0 = plain majority (2)',
    'max_pairs': 'pair-instants scored per chunk: bounds the memory (1000000)',
}
ORDER = ('exact', 'glr', 'glr_thresholded', 'mc')
assert set(ORDER) == set(METHODS)


@dataclass
class Settings:
    """Association settings shared by the experiment and its tests (defaults = the experiment's)."""

    window: int = 1
    mean: str = 'geometric'
    threshold: float = THRESHOLD
    n_samples: int = 500
    tol: float = 1e-3
    gate: bool = True
    prior_weight: float = SHORT_PAIR_WEIGHT  # short-pair rule (association module docstring); 0: plain majority
    prior_rate: float = SHORT_PAIR_RATE
    max_pairs: int = 1_000_000           # pair-instants per scored chunk (bounds the memory)


WINDOWS = ((1, 'W=1 (default)'), (3, 'W=3'), (10, 'W=10'), (None, 'all instants'))
THRESHOLDS = (0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9)


@dataclass
class MethodResult:
    metrics: Metrics                 # one-to-one decisions
    threshold_only: Metrics          # threshold + majority, before one-to-one
    geometry_evaluations: int
    seconds: float
    stream: StreamingDecisions       # per-pair sums of every accumulated rule (ablations)
    decisions: PairDecisions | None = None


@dataclass
class RunResult:
    radar: SourceReports | None      # kept with keep_decisions (the map), else None (memory)
    patrol: SourceReports | None
    pair_instants: int
    mmsi_radar: np.ndarray
    mmsi_patrol: np.ndarray
    methods: dict[str, MethodResult] = field(default_factory=dict)
    chunks: int = 0


def _rules(s: Settings) -> dict[tuple[int | None, str], list[float]]:
    rules = {(w, s.mean): [s.threshold] for w, _ in WINDOWS}
    rules[s.window, s.mean] = sorted({s.threshold, *THRESHOLDS})
    return rules


def run_once(truth: ShipTruth, seed: int, *, radar: SourceModel = RADAR, patrol: SourceModel = PATROL,
             methods=ORDER, t_start: float = 0.0, t_end: float | None = None,
             settings: Settings | None = None, keep_decisions: bool = False) -> RunResult:
    """One realisation: simulate both sources with ``seed``, score and decide with every method.

    The pair-instants are scored chunk by chunk (``Settings.max_pairs``,
    :func:`~.association.pair_tables`); only per-track-pair sums are kept.
    """
    s = settings or Settings()
    rng = np.random.default_rng(seed)
    a = simulate_source(truth, radar, rng, t_start, t_end)
    b = simulate_source(truth, patrol, rng, t_start, t_end)
    mc_rng = np.random.default_rng([seed, 1])
    rules = _rules(s)
    streams = {m: StreamingDecisions(len(a.ids), len(b.ids), rules) for m in methods}
    secs, n_geom = dict.fromkeys(methods, 0.0), dict.fromkeys(methods, 0)
    n_pairs = chunks = 0
    for table in pair_tables(a, b, s.max_pairs, s.tol):
        n_pairs += len(table)
        chunks += 1
        for m in methods:
            t0 = time.perf_counter()
            g, n = table.score(m, n_samples=s.n_samples, rng=mc_rng, gate=s.gate)
            secs[m] += time.perf_counter() - t0
            n_geom[m] += n
            streams[m].add(table, g)
        del table, g
    keep = keep_decisions
    out = RunResult(a if keep else None, b if keep else None, n_pairs, a.mmsi, b.mmsi, chunks=chunks)
    rule = {'prior_weight': s.prior_weight, 'prior_rate': s.prior_rate}
    for m in methods:
        raw = streams[m].decide(s.window, s.mean, s.threshold, **rule)
        dec = streams[m].decide(s.window, s.mean, s.threshold, one_to_one=True, **rule)
        out.methods[m] = MethodResult(evaluate(a, b, dec), evaluate(a, b, raw), n_geom[m], secs[m], streams[m],
                                      dec if keep_decisions else None)
    return out


def decide(run: RunResult, method: str, *, window: int | None, threshold: float, mean: str = 'geometric',
           one_to_one: bool = True, prior_weight: float = 0.0, prior_rate: float = 0.8) -> Metrics:
    """Metrics of ``method`` under another accumulated decision rule (ablations)."""
    dec = run.methods[method].stream.decide(window, mean, threshold, one_to_one=one_to_one,
                                            prior_weight=prior_weight, prior_rate=prior_rate)
    return evaluate_mmsi(run.mmsi_radar, run.mmsi_patrol, dec)


def _pool(ms: list[Metrics]) -> Metrics:
    return Metrics(sum(m.tp for m in ms), sum(m.fp for m in ms), sum(m.fn for m in ms),
                   sum(m.undecidable for m in ms))


def _describe(model: SourceModel) -> str:
    where = {'fixed': f'at {model.bearing_deg:g}°', 'radial': 'across the beam', 'random': 'at random bearings'}
    return (f'{model.name}: 1σ {model.sigma_major:g} m × {model.sigma_minor:g} m {where[model.orientation]}, '
            f'every {model.period:g} s, {100 * model.dropout:g} % missed')



def plot_map(path, truth: ShipTruth, res: RunResult, method: str, radar: SourceModel) -> None:
    """Map of the ships: true tracks in grey, each associated track pair in its own colour."""
    plt = pyplot()
    a, b = res.radar, res.patrol
    dec = res.methods[method].decisions
    assert dec is not None
    f, axes = plt.subplots(1, 2, figsize=(14, 6.5), gridspec_kw={'width_ratios': [1.35, 1]})
    cmap = plt.get_cmap('tab20')
    pairs = [(int(x), int(y)) for x, y in zip(dec.a[dec.declared], dec.b[dec.declared], strict=True)]
    wrong = [(x, y) for x, y in pairs if a.mmsi[x] != b.mmsi[y]]
    partner = dict(pairs)
    # zoom: the densest 4 km square (Portsmouth harbour in the Solent data)
    centre = np.median(a.truth, axis=0)
    for ax, zoom in ((axes[0], False), (axes[1], True)):
        for xy in truth.xy:
            ax.plot(xy[:, 0] / 1e3, xy[:, 1] / 1e3, '-', color='0.8', lw=0.8, zorder=1)
        for ta in range(len(a.ids)):
            sel = a.track == ta
            if not sel.any():
                continue
            xy = a.mu[sel] / 1e3
            if ta in partner:
                c = cmap(ta % 20)
                ax.plot(xy[:, 0], xy[:, 1], '.', color=c, ms=1.5, zorder=2)
                pb = b.mu[b.track == partner[ta]] / 1e3
                ax.plot(pb[:, 0], pb[:, 1], 'x', color=c, ms=3, mew=0.8, zorder=3)
            else:
                ax.plot(xy[:, 0], xy[:, 1], '.', color='k', ms=1.0, zorder=2)
        for tb in sorted(set(range(len(b.ids))) - set(partner.values())):
            pb = b.mu[b.track == tb] / 1e3
            ax.plot(pb[:, 0], pb[:, 1], 'x', color='k', ms=3, mew=0.6, zorder=3)
        for x, y in wrong:
            p = np.vstack([a.mu[a.track == x].mean(0), b.mu[b.track == y].mean(0)]) / 1e3
            ax.plot(p[:, 0], p[:, 1], 'r-', lw=2, zorder=4)
            ax.plot(*p[0], 'o', mfc='none', mec='r', ms=10, zorder=4)
        s = resolve_site(truth, radar.site) / 1e3
        ax.plot(*s, 'k^', ms=9, zorder=5, label=f'{radar.name} site')
        ax.set_aspect('equal')
        ax.set_xlabel('east [km]')
        ax.set_ylabel('north [km]')
        if zoom:
            c = centre / 1e3
            ax.set_xlim(c[0] - 2, c[0] + 2)
            ax.set_ylim(c[1] - 2, c[1] + 2)
            ax.set_title('zoom: the densest 4 km × 4 km')
    m = res.methods[method].metrics
    axes[0].plot([], [], '-', color='0.8', label='AIS truth (interpolated)')
    axes[0].plot([], [], '.', color='tab:blue', label=f'{a.name} reports (colour = associated pair)')
    axes[0].plot([], [], 'x', color='tab:blue', label=f'{b.name} reports, same colour as their {a.name} track')
    axes[0].plot([], [], '.', color='k', label='not associated')
    axes[0].plot([], [], 'r-', lw=2, label='wrong association')
    axes[0].legend(loc='lower left', fontsize=8)
    axes[0].set_title(f'{method}: {len(pairs)} pairs declared, precision {m.precision:.3f}, recall {m.recall:.3f}, '
                      f'F1 {m.f1:.3f}', fontsize=10)
    f.tight_layout()
    f.savefig(path, dpi=110)
    plt.close(f)


def plot_sweep(path, scales, f1: dict[str, list[float]]) -> None:
    plt = pyplot()
    f, ax = plt.subplots(figsize=(6, 4))
    for m in ORDER:
        ax.plot(scales, f1[m], 'o-', label=m)
    ax.set_xscale('log', base=2)
    ax.set_xlabel('ellipse scale k (both sources, 1σ × k)')
    ax.set_ylabel('F1 (one-to-one)')
    ax.set_ylim(-0.02, 1.02)
    ax.grid(alpha=0.3)
    ax.legend()
    f.tight_layout()
    f.savefig(path, dpi=100)
    plt.close(f)


def _pooled(results: list[RunResult], method: str, **rule) -> Metrics:
    return _pool([decide(r, method, **rule) for r in results])


def _option_float(cfg: RunConfig, key: str, default, off: dict | None = None):
    off = off or {}
    v = cfg.options.get(key)
    if v is None:
        return default
    v = v.strip()
    if v in off:
        return off[v]
    try:
        return float(v)
    except ValueError:
        raise ValueError(f'--set {key}={v!r}: expected a number{" or " + ", ".join(off) if off else ""}') from None


def _site(text: str | None, default):
    if text is None:
        return default
    text = text.strip()
    if text.startswith('hull:') or text == 'origin':
        return None if text == 'origin' else text
    try:
        lat, lon = (float(x) for x in text.split(','))
    except ValueError:
        raise ValueError(f"--set radar_site={text!r}: expected 'hull:<bearing>', 'origin' or 'lat,lon'") from None
    return lat, lon


def setup(cfg: RunConfig, data: AisData | None = None) -> tuple[AisData, ShipTruth, SourceModel, Settings]:
    """The data, truth, radar model and settings of a run from ``cfg.options`` (the module docstring's keys)."""
    if (problem := unknown_keys_problem(ais_association, cfg.options)) is not None:
        raise ValueError(problem)
    if data is None:
        region = _option_float(cfg, 'max_distance_km', 'auto', {'auto': 'auto', 'off': None})
        data = read_ais(cfg.options.get('file') or None, columns=cfg.options.get('columns') or None,
                        max_distance_km=region)
    truth = ShipTruth(data, max_gap=_option_float(cfg, 'max_gap', None, {'auto': None}))
    radar = replace(RADAR, site=_site(cfg.options.get('radar_site'), RADAR.site))
    settings = Settings(prior_weight=_option_float(cfg, 'prior_weight', Settings.prior_weight),
                        max_pairs=int(_option_float(cfg, 'max_pairs', Settings.max_pairs)))
    return data, truth, radar, settings


def derived_defaults(data: AisData, truth: ShipTruth, radar: SourceModel) -> dict:
    """What the run derived from the data: region radius, COG/SOG origin, columns, gap limits, radar site."""
    site_xy = resolve_site(truth, radar.site)
    return {'max_distance_km': data.derived.get('max_distance_km'), 'region_rule': data.derived.get('region_rule'),
            'cog_sog': data.derived.get('cog_sog'), 'columns': data.derived.get('columns'),
            'gap': truth.gap_summary(),
            'radar_site': {'rule': radar.site if isinstance(radar.site, str) else 'fixed',
                           'lat_lon': [float(v) for v in truth.plane.inverse(site_xy)],
                           'east_north_m': [float(v) for v in site_xy]},
            'origin_lat_lon': [truth.plane.lat0, truth.plane.lon0]}


def peak_rss_mb() -> float:
    """Peak resident memory of this process so far [MB] (``getrusage``: kB on Linux, bytes on macOS)."""
    import resource
    import sys

    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak / 2**20 if sys.platform == 'darwin' else peak / 1024


def _noise_sweep(cfg, truth, radar, patrol, scales, seeds, t_end, settings, results):
    """F1 per method with both sources' ellipses scaled by k (same seeds: the same draws, scaled)."""
    sweep, sweep_f1 = [], {m: [] for m in ORDER}
    for k in cfg.progress(scales, desc='noise sweep'):
        if k == 1.0:
            per = {m: _pool([r.methods[m].metrics for r in results]) for m in ORDER}
        else:
            rs = [run_once(truth, s, radar=radar.scaled(k), patrol=patrol.scaled(k), t_end=t_end,
                           settings=settings) for s in seeds]
            per = {m: _pool([r.methods[m].metrics for r in rs]) for m in ORDER}
            del rs
        sweep.append({'scale': k, 'radar_sigma': [radar.sigma_major * k, radar.sigma_minor * k],
                      'patrol_sigma': [patrol.sigma_major * k, patrol.sigma_minor * k],
                      **{m: per[m].as_dict() for m in ORDER}})
        for m in ORDER:
            sweep_f1[m].append(per[m].f1)
    return sweep, sweep_f1


@set_keys(**OPTIONS)
def ais_association(cfg: RunConfig, data: AisData | None = None) -> Outcome:
    """Precision/recall/F1 of same-ship decisions per method, pair evaluations, noise sweep, map."""
    data, truth, radar, settings = setup(cfg, data)
    patrol = PATROL
    runs = cfg.n_runs(full=3, quick=1)
    duration = _option_float(cfg, 'duration', 900.0 if cfg.quick else truth.t_end)
    t_end = min(duration, truth.t_end)
    default_scales = '1,4' if cfg.quick else '0.5,1,2,4,8'
    try:
        scales = [float(x) for x in cfg.options.get('sweep', default_scales).split(',') if x.strip()]
    except ValueError:
        raise ValueError(f'--set sweep={cfg.options["sweep"]!r}: expected comma-separated scales') from None
    seeds = [cfg.seed + r for r in range(runs)]
    results = [run_once(truth, s, radar=radar, patrol=patrol, t_end=t_end, settings=settings,
                        keep_decisions=(k == 0))
               for k, s in enumerate(cfg.progress(seeds, desc='ais-association'))]
    pairs_scored = int(np.mean([r.pair_instants for r in results]))
    hours = t_end / 3600.0
    ships = int(sum(t[0] <= t_end for t in truth.times))
    both = int(np.mean([np.intersect1d(r.mmsi_radar, r.mmsi_patrol).size for r in results]))
    methods, rows = {}, []
    for m in ORDER:
        pooled = _pool([r.methods[m].metrics for r in results])
        raw = _pool([r.methods[m].threshold_only for r in results])
        geom = int(np.mean([r.methods[m].geometry_evaluations for r in results]))
        secs = float(np.mean([r.methods[m].seconds for r in results]))
        methods[m] = {**pooled.as_dict(), 'threshold_only': raw.as_dict(), 'geometry_evaluations': geom,
                      'seconds': secs, 'evaluations_per_second': pairs_scored / secs if secs > 0 else None}
        rows.append([m, pooled.precision, pooled.recall, pooled.f1, raw.precision, raw.recall, raw.f1, geom,
                     secs])
    rule = {'prior_weight': settings.prior_weight, 'prior_rate': settings.prior_rate}
    # decision-rule ablation: the paper's geometric mean over longer windows, down to all instants
    ablation = [{'window': w, 'label': lab,
                 **{m: _pooled(results, m, window=w, threshold=settings.threshold, **rule).as_dict() for m in ORDER}}
                for w, lab in WINDOWS]
    thr_sweep = [{'threshold': th, **{m: _pooled(results, m, window=settings.window, threshold=th, **rule).f1
                                      for m in ORDER}} for th in THRESHOLDS]
    # the short-pair rule against the plain majority (same scores)
    short = [{'prior_weight': nu, 'label': lab,
              **{m: _pooled(results, m, window=settings.window, threshold=settings.threshold, prior_weight=nu,
                            prior_rate=settings.prior_rate).as_dict() for m in ORDER}}
             for nu, lab in ((0.0, 'plain majority (ν = 0)'),
                             (settings.prior_weight, f'short-pair prior (ν = {settings.prior_weight:g})'))]
    sweep, sweep_f1 = _noise_sweep(cfg, truth, radar, patrol, scales, seeds, t_end, settings, results)
    cfg.out.mkdir(parents=True, exist_ok=True)
    fig_map, fig_sweep = cfg.out / 'ais-association.png', cfg.out / 'ais-noise-sweep.png'
    plot_map(fig_map, truth, results[0], 'exact', radar)
    plot_sweep(fig_sweep, scales, sweep_f1)

    derived = derived_defaults(data, truth, radar)
    gaps, site_ll = derived['gap'], derived['radar_site']['lat_lon']
    head = [
        f'AIS file: {data.describe()}',
        *[f'WARNING {w}' for w in data.warnings],
        f'derived defaults: gap limit {gaps["rule"]}: {gaps["limit_min_s"]:.0f}–{gaps["limit_max_s"]:.0f} s '
        f'(median {gaps["limit_median_s"]:.0f} s), {100 * gaps["gaps_bridged"]:.2f} % of the gaps bridged, ships '
        f'known {100 * gaps["time_known"]:.1f} % of their lifetimes; radar site {radar.site} at '
        f'{site_ll[0]:.4f}°, {site_ll[1]:.4f}°',
        f'window: {t_end / 60:.1f} min, {ships} ships, {both} seen by both sources; {runs} noise realisation(s) '
        f'pooled (seeds {seeds[0]}..{seeds[-1]})',
        f'sources: {_describe(radar)}; {_describe(patrol)}',
        f'decision: associated at an instant when the score (geometric mean over the last {settings.window} '
        f'common instant(s)) is ≥ {settings.threshold}; same ship when k of n instants associated with k ≥ 1 and '
        f'(k + {settings.prior_weight:g}·{settings.prior_rate:g}) / (n + {settings.prior_weight:g}) ≥ 1/2; then '
        'one-to-one (Hungarian). "thr-only": before one-to-one',
        f'pair evaluations per method: {pairs_scored} in {t_end / 60:.1f} min of data = '
        f'{pairs_scored / hours:,.0f} per hour (paper: {PAPER_EVALS_PER_HOUR:,} per hour operationally), scored in '
        f'{results[0].chunks} chunk(s) of ≤ {settings.max_pairs:,}; exact, glr_thresholded and mc compute the '
        'geometry only for pairs whose 2σ ellipses can touch ("geometry evals"; the others are exactly 0)',
    ]
    table = format_table(['method', 'precision', 'recall', 'F1', 'thr-only P', 'thr-only R', 'thr-only F1',
                          'geometry evals', 'seconds'], rows)
    abl_table = format_table(['rule (geometric mean)', *[f'F1 {m}' for m in ORDER]],
                             [[a['label'], *[a[m]['f1'] for m in ORDER]] for a in ablation])
    short_table = format_table(['pair verdict', *[f'{h} {m}' for m in ORDER for h in ('P', 'R', 'F1')]],
                               [[x['label'], *[x[m][h] for m in ORDER for h in ('precision', 'recall', 'f1')]]
                                for x in short])
    thr_table = format_table(['threshold', *[f'F1 {m}' for m in ORDER]],
                             [[t['threshold'], *[t[m] for m in ORDER]] for t in thr_sweep])
    sweep_table = format_table(
        ['scale k', 'radar 1σ [m]', 'patrol 1σ [m]', *[f'F1 {m}' for m in ORDER]],
        [[k['scale'], f'{k["radar_sigma"][0]:g}×{k["radar_sigma"][1]:g}',
          f'{k["patrol_sigma"][0]:g}×{k["patrol_sigma"][1]:g}', *[k[m]['f1'] for m in ORDER]] for k in sweep])
    peak = peak_rss_mb()
    text = '\n'.join([*head, table,
                      'decision rule: window of the instant-score mean (one-to-one, threshold 0.5):', abl_table,
                      'short pairs: the pair verdict (W=1, threshold 0.5, one-to-one):', short_table,
                      'threshold (default rule, one-to-one):', thr_table,
                      "noise sweep (both sources' ellipses × k, default rule):", sweep_table,
                      f'peak memory (resident): {peak:.0f} MB'])
    payload = {
        'ships': ships, 'ships_in_both_sources': both, 'pairs_scored': pairs_scored,
        'pairs_scored_per_hour': pairs_scored / hours, 'paper_evaluations_per_hour': PAPER_EVALS_PER_HOUR,
        'methods': methods, 'noise_sweep': sweep, 'rule_ablation': ablation, 'threshold_sweep': thr_sweep,
        'short_pair_rule': short, 'runs': runs, 'seeds': seeds, 'duration_s': t_end,
        'file': str(data.path) if data.path is not None else None,
        'rows': data.rows, 'rows_kept': int(data.t.size), 'rows_skipped': data.n_skipped,
        'skipped': {k: v for k, v in data.skipped.items() if v}, 'warnings': data.warnings,
        'derived_defaults': derived, 'peak_rss_mb': peak, 'chunks': results[0].chunks,
        'sources': {m.name: {'sigma_major': m.sigma_major, 'sigma_minor': m.sigma_minor, 'period': m.period,
                             'dropout': m.dropout, 'orientation': m.orientation} for m in (radar, patrol)},
        'settings': {'window': settings.window, 'mean': settings.mean, 'threshold': settings.threshold,
                     'n_samples': settings.n_samples, 'one_to_one': True, 'prior_weight': settings.prior_weight,
                     'prior_rate': settings.prior_rate, 'max_pairs': settings.max_pairs},
    }
    return Outcome(text, payload, [fig_map, fig_sweep])

"""The ``maritime`` scenario's summary (``maritime_metrics``, the launcher's and ``track-summary``'s): per
tracker RTAMS, convergence and pings, per pair the mean score and the verdict, and the picture.

What is measured and how is ``report.maritime``'s (its module doc); the picture is ``maritime_picture``'s.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from track_core.metrics import rms
from track_nodes.report.maritime import (
    NETWORK_TRACK,
    PICTURE,
    RADAR_DECOY,
    SONAR_TRACK,
    TRACKERS,
    converged_at,
    load,
    run_start,
    start_note,
    tracker_errors,
    verdicts,
)
from track_nodes.report.maritime_picture import picture


def maritime_metrics(bag: Path) -> list[str]:
    return summary_lines(load(bag), bag / PICTURE)


def summary_lines(d: dict, picture_path: Path) -> list[str]:
    """The summary of loaded data ``d`` (``load``); writes the picture to ``picture_path``."""
    errors = tracker_errors(d)
    start = run_start(d)
    n_pings = len(d['pings'])
    lines = [start_note(start),
             f'{"tracker":<16} {"target":<13} {"estimates":>9} {"RTAMS":>9} {"converged":>10} {"pings":>6} '
             f'{"detected":>8}']
    for track_id, (label, _, _, child) in TRACKERS.items():
        t, err = errors[track_id]
        sonar = track_id == SONAR_TRACK
        conv = converged_at(t, err) if t.size else float('inf')
        lines.append(f'{label:<16} {child.replace("t0", "decoy"):<13} {t.size:>9} '
                     f'{(f"{rms(err[:, None]):.1f} m" if t.size else "-"):>9} '
                     f'{(f"t={conv - start:.1f} s" if np.isfinite(conv) else "never"):>10} '
                     f'{(str(n_pings) if sonar else "-"):>6} {(str(d["detections"]) if sonar else "-"):>8}')
    v = verdicts(d, errors)
    lines.extend(true_pair_lines(v))
    if not v:
        lines.append('fusion: no scores recorded')
    else:
        lines.append(f'{"pair":<34} {"mean score":>10} {"assoc. after conv.":>18} {"verdict":>14} {"truth":>6}')
        for (a, b), r in sorted(v.items()):
            same = TRACKERS.get(a, ('',) * 4)[3] == TRACKERS.get(b, ('',) * 4)[3]
            name = f'{TRACKERS.get(a, (a,))[0]} | {TRACKERS.get(b, (b,))[0]}'
            frac = '-' if np.isnan(r['fraction']) else f'{100 * r["fraction"]:.0f}%'
            lines.append(f'{name:<34} {r["mean_score"]:>10.3f} {frac:>18} '
                         f'{"associated" if r["associated"] else "not assoc.":>14} {"same" if same else "diff":>6}')
    try:
        path = picture(d, picture_path, errors, v)
        lines.append(f'picture: {path.resolve()}')
    except Exception as exc:  # the summary must still print; the reason is one line
        lines.append(f'picture: not written ({type(exc).__name__}: {exc})')
    return lines


def true_pair_lines(v: dict) -> list[str]:
    """The goal: the sonar|network pair associated at ≥ 95 % of the instants after both converged,
    and the decoy's pairs never."""
    pair = tuple(sorted((SONAR_TRACK, NETWORK_TRACK)))
    if pair not in v or np.isnan(v[pair]['fraction']):
        return ['true pair (sonar | network): no scored instant after both converged']
    r = v[pair]
    n = r['instants_after']
    decoy = [p for p in v if RADAR_DECOY in p and v[p]['ever']]
    return [f'true pair (sonar | network) associated at {100 * r["fraction"]:.1f}% of {n} instants after both '
            f'converged (goal >= 95%); decoy pairs associated at any instant: {len(decoy)}']


# --- picture --------------------------------------------------------------------------------------

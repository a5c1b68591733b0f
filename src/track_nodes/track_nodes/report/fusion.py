"""Summary of the fusion scenario: mean score and association time per pair of tracks."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from track_msgs_py.records.fusion import FusionPairs
from track_msgs_py.topics import FUSION_SCORES
from track_nodes.report.read import read_topics


def pair_verdicts(bag: Path, topic: str = FUSION_SCORES) -> dict[tuple[str, str], dict]:
    """Per pair from the fusion scores: mean instant score, fraction associated, last verdict."""
    stats: dict[tuple[str, str], dict] = {}
    for arr in read_topics(bag, {topic}).get(topic, []):
        for pair, score, _, _, associated in FusionPairs.from_msg(arr).rows():
            rec = stats.setdefault(pair, {'scores': [], 'associated': []})
            rec['scores'].append(score)
            rec['associated'].append(associated)
    return {pair: {'mean_score': float(np.mean(r['scores'])), 'fraction_associated': float(np.mean(r['associated'])),
                   'final': r['associated'][-1], 'instants': len(r['scores'])} for pair, r in stats.items()}


def same_simulated_ship(a: str, b: str) -> bool:
    """report_source tracks ``<prefix>/t<i>`` of sources sharing one truth are the same ship iff i matches."""
    return a.rsplit('/', 1)[-1] == b.rsplit('/', 1)[-1]


def fusion_metrics(bag: Path) -> list[str]:
    verdicts = pair_verdicts(bag)
    if not verdicts:
        return ['fusion: no scores recorded']
    lines = [f'{"pair":<26} {"mean score":>10} {"assoc. time":>11} {"final":>6} {"truth":>6}']
    for (a, b), v in sorted(verdicts.items()):
        lines.append(f'{a + " | " + b:<26} {v["mean_score"]:>10.3f} {100 * v["fraction_associated"]:>10.0f}% '
                     f'{"yes" if v["final"] else "no":>6} {"same" if same_simulated_ship(a, b) else "diff":>6}')
    return lines

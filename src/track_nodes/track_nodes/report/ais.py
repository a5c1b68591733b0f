"""Summary of the ais scenarios: the recorded same-ship verdicts against the MMSI.

Truth of a simulated source: its ``/ais/<source>/truth`` table. A live AIS source
(``ais_nmea_source``, ``/ais/<prefix>/tracks``) needs none: its track id is the MMSI, so a live track
is its own truth, and the summary also counts its tracks and reports per MMSI.
"""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

import numpy as np

from track_core.ais import Metrics, match_one_to_one
from track_core.ais.association import SHORT_PAIR_RATE, SHORT_PAIR_WEIGHT, declare
from track_msgs_py.records.fusion import AisTruthEntry, FusionPairs
from track_msgs_py.topics import FUSION_SCORES
from track_nodes.report.read import read_topics, topics_matching


def _live_tracks(msgs, topics, mmsi: dict[str, int], ships_by_source: dict[str, set[int]]) -> list[str]:
    """A live source's tracks are their own truth (track id = MMSI): added to ``mmsi``; one line per topic."""
    lines = []
    for topic in topics:
        reports: dict[int, int] = defaultdict(int)
        for arr in msgs.get(topic, []):
            for track in arr.tracks:
                if track.id.isdigit():
                    reports[int(track.id)] += 1
                    mmsi[f'{topic}/{track.id}'] = int(track.id)
                    ships_by_source[topic].add(int(track.id))
        if reports:
            n = np.array(list(reports.values()))
            lines.append(f'  {topic}: {len(reports)} tracks, one per MMSI; {int(n.sum())} reports, '
                         f'{int(np.median(n))} per MMSI (median; {int(n.min())}–{int(n.max())})')
    return lines


def ais_metrics(bag: Path) -> list[str]:
    """AIS scenario: the recorded same-ship verdicts against the MMSI, for the fusion's method.

    Truth: the ``/ais/<source>/truth`` tables (local track → MMSI, evaluation only). Verdicts:
    every pair of ``/fusion/scores``; a pair with k of its n scored instants associated is declared the
    same ship by the short-pair rule (``association.declare`` with ν = ``SHORT_PAIR_WEIGHT``, r̄ =
    ``SHORT_PAIR_RATE``: k ≥ 1 and (k + ν·r̄)/(n + ν) ≥ 1/2, as ``track-experiment ais-association``), then made
    one-to-one (Hungarian on the pair's mean score, ``track_core.ais.match_one_to_one``). Precision =
    right / declared, recall = right / same-ship pairs that were scored at least once.
    """
    truth_topics = topics_matching(bag, lambda topic: topic.startswith('/ais/') and topic.endswith('/truth'))
    live_topics = topics_matching(bag, lambda topic: topic.startswith('/ais/') and topic.endswith('/tracks'))
    msgs = read_topics(bag, {*truth_topics, *live_topics, FUSION_SCORES})
    mmsi: dict[str, int] = {}
    ships_by_source: dict[str, set[int]] = defaultdict(set)
    for topic in truth_topics:
        for arr in msgs.get(topic, [])[-1:]:
            for st in arr.status:
                mmsi[st.name] = AisTruthEntry.from_status(st).mmsi
                ships_by_source[topic].add(mmsi[st.name])
    live_lines = _live_tracks(msgs, live_topics, mmsi, ships_by_source)
    pairs: dict[tuple[str, str], list] = {}
    methods, evaluations = set(), 0
    for arr in msgs.get(FUSION_SCORES, []):
        scored = FusionPairs.from_msg(arr)
        methods.add(scored.method)
        for pair, score, _, _, associated in scored.rows():
            rec = pairs.setdefault(tuple(sorted(pair)), [0.0, 0, 0])  # fusion orders a pair by first report
            rec[0] += score
            rec[1] += associated
            rec[2] += 1
            evaluations += 1
    if not mmsi or not pairs:
        return [f'ais: {"no truth tables" if not mmsi else "no fusion scores"} recorded']
    keys = [p for p in pairs if p[0] in mmsi and p[1] in mmsi]
    if not keys:
        return ['ais: no scored pair has a truth entry (were /ais/*/truth recorded?)']
    same = np.array([mmsi[a] == mmsi[b] for a, b in keys])
    mean = np.array([pairs[p][0] / pairs[p][2] for p in keys])
    declared = declare(np.array([pairs[p][2] for p in keys], float), np.array([pairs[p][1] for p in keys], float),
                       SHORT_PAIR_WEIGHT, SHORT_PAIR_RATE)
    ids = {name: k for k, name in enumerate(sorted({x for p in keys for x in p}))}
    pa = np.array([ids[a] for a, _ in keys])
    pb = np.array([ids[b] for _, b in keys])
    source_pair = np.array([f'{a.rsplit("/", 1)[0]} | {b.rsplit("/", 1)[0]}' for a, b in keys])
    matched = np.zeros_like(declared)
    for sp in np.unique(source_pair):  # one assignment per pair of sources
        sel = np.flatnonzero((source_pair == sp) & declared)
        if sel.size:
            matched[sel] = match_one_to_one(pa[sel], pb[sel], mean[sel], np.ones(sel.size, bool))
    sources = sorted(ships_by_source)
    both = set.intersection(*ships_by_source.values()) if len(sources) >= 2 else set()
    undecidable = len(both) - int(same.sum())

    def metrics(d: np.ndarray) -> Metrics:
        return Metrics(int(np.sum(d & same)), int(np.sum(d & ~same)), int(np.sum(~d & same)), undecidable)

    lines = [f'ais: method {"/".join(sorted(methods))}; '
             + ', '.join(f'{t.split("/")[2]} {len(ships_by_source[t])} tracks' for t in sources)
             + f'; {len(both)} ships seen by both; {evaluations} pair evaluations, {len(keys)} track pairs, '
             f'{int(same.sum())} of them the same ship', *live_lines]
    rule = f'short-pair rule (k ≥ 1, (k + {SHORT_PAIR_WEIGHT:g}·{SHORT_PAIR_RATE:g})/(n + {SHORT_PAIR_WEIGHT:g}) ≥ 1/2)'
    for label, d in ((rule, declared), ('one-to-one', matched)):
        m = metrics(d)
        lines.append(f'  {label:<50} precision {m.precision:.3f}  recall {m.recall:.3f}  F1 {m.f1:.3f}  '
                     f'(TP {m.tp}, FP {m.fp}, FN {m.fn})')
    wrong = [k for k in np.flatnonzero(matched & ~same)][:5]
    missed = [k for k in np.flatnonzero(~matched & same)][:5]
    for k in wrong:
        lines.append(f'  wrong:  {keys[k][0]} | {keys[k][1]} (mean score {mean[k]:.2f}, MMSI {mmsi[keys[k][0]]} vs '
                     f'{mmsi[keys[k][1]]})')
    for k in missed:
        lines.append(f'  missed: {keys[k][0]} | {keys[k][1]} (mean score {mean[k]:.2f}, associated '
                     f'{pairs[keys[k]][1]}/{pairs[keys[k]][2]} instants)')
    return lines

"""Typed records of the fusion system: the pairs of an instant, the fused pairs, the AIS truth entry.

=========================  ==========================================  ===============================================
record                     message type                                fields
=========================  ==========================================  ===============================================
``FusionPairs``: the       track_msgs/PairScoreArray                   ``header`` (stamp ← t, frame_id), ``method``,
scored pairs of one                                                    ``combine``, ``window``, ``threshold``;
instant, as columns                                                    ``pairs[k]``: ``a``, ``b``, ``score``,
                                                                       ``combined``, ``instants``, ``associated``
``FusedTracks``: the       track_msgs/FusedTrackArray                  ``header``; ``tracks[k]``: ``a``, ``b``, ``x``,
associated pairs fused                                                 ``y``, ``covariance`` (2×2 row-major)
``AisTruthEntry``          DiagnosticStatus of ``<prefix>/truth``      name = track id, ``mmsi``, ``reports``
=========================  ==========================================  ===============================================

The fusion node publishes one ``PairScoreArray`` per instant on ``/fusion/scores`` (and the
associated pairs on ``/fusion/associations``) and one ``FusedTrackArray`` on ``/fusion/fused``;
the fusion, ais and maritime summaries and the tests read them back with ``from_msg``. Scores
travel as float64. ``AisTruthEntry``: one status per local track of an ``ais_source``, named like
the fusion node's track id ``<prefix>/reports/<local id>``, message ``evaluation only``: the
ship's MMSI and how many reports the source makes of it; the fusion node never reads it.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass, replace
from typing import Self

import numpy as np
from diagnostic_msgs.msg import DiagnosticStatus

from track_msgs.msg import FusedTrack, FusedTrackArray, PairScore, PairScoreArray
from track_msgs_py.records import DIAG_OK, RecordError, StatusRecord
from track_msgs_py.stamps import stamp_to_sec, stamped_header
from track_msgs_py.topics import FRAME_MAP


@dataclass(frozen=True, eq=False)
class FusionPairs:
    """The pairs of one instant: track ids ``a``, ``b`` and the columns, with the rule that judged them."""

    t: float
    a: Sequence[str]
    b: Sequence[str]
    score: np.ndarray
    combined: np.ndarray
    instants: np.ndarray
    associated: np.ndarray
    method: str
    combine: str
    window: int
    threshold: float
    frame_id: str = FRAME_MAP

    def __len__(self) -> int:
        return len(self.a)

    def select(self, mask) -> FusionPairs:
        """The pairs where ``mask`` holds (e.g. ``pairs.associated``)."""
        k = np.flatnonzero(mask)
        return replace(self, a=[self.a[i] for i in k], b=[self.b[i] for i in k], score=self.score[k],
                       combined=self.combined[k], instants=self.instants[k], associated=self.associated[k])

    def rows(self) -> Iterator[tuple[tuple[str, str], float, float, int, bool]]:
        """((a, b), score, combined, instants, associated) per pair."""
        for k in range(len(self)):
            yield ((self.a[k], self.b[k]), float(self.score[k]), float(self.combined[k]), int(self.instants[k]),
                   bool(self.associated[k]))

    def to_msg(self) -> PairScoreArray:
        msg = PairScoreArray(header=stamped_header(self.t, self.frame_id), method=self.method,
                             combine=self.combine, window=int(self.window), threshold=float(self.threshold))
        msg.pairs = [PairScore(a=a, b=b, score=s, combined=c, instants=n, associated=v)
                     for a, b, s, c, n, v in zip(self.a, self.b, self.score.tolist(), self.combined.tolist(),
                                                 self.instants.tolist(), self.associated.tolist(), strict=True)]
        return msg

    @classmethod
    def from_msg(cls, msg) -> Self:
        """The record of a ``PairScoreArray`` (an rclpy or rosbags message); ``RecordError`` on a pair without ids."""
        p = msg.pairs
        bad = next((k for k, q in enumerate(p) if not q.a or not q.b), None)
        if bad is not None:
            raise RecordError(f'fusion pairs: pair {bad} has an empty track id ({p[bad].a!r}, {p[bad].b!r})')
        return cls(stamp_to_sec(msg.header.stamp), [q.a for q in p], [q.b for q in p],
                   np.array([q.score for q in p], float), np.array([q.combined for q in p], float),
                   np.array([q.instants for q in p], np.int64), np.array([q.associated for q in p], bool),
                   msg.method, msg.combine, int(msg.window), float(msg.threshold), msg.header.frame_id)


@dataclass(frozen=True, eq=False)
class FusedTracks:
    """The associated pairs (a, b) of one instant fused: positions ``mu`` (n, 2), covariances ``P`` (n, 2, 2)."""

    t: float
    a: Sequence[str]
    b: Sequence[str]
    mu: np.ndarray
    P: np.ndarray
    frame_id: str = FRAME_MAP

    def __len__(self) -> int:
        return len(self.a)

    def to_msg(self) -> FusedTrackArray:
        msg = FusedTrackArray(header=stamped_header(self.t, self.frame_id))
        P = np.asarray(self.P, float).reshape(-1, 4)
        msg.tracks = [FusedTrack(a=a, b=b, x=x, y=y, covariance=c)
                      for a, b, (x, y), c in zip(self.a, self.b, np.asarray(self.mu, float).reshape(-1, 2).tolist(),
                                                 P, strict=True)]
        return msg

    @classmethod
    def from_msg(cls, msg) -> Self:
        k = msg.tracks
        P = np.array([np.asarray(q.covariance, float) for q in k], float).reshape(-1, 2, 2)
        return cls(stamp_to_sec(msg.header.stamp), [q.a for q in k], [q.b for q in k],
                   np.array([(q.x, q.y) for q in k], float).reshape(-1, 2), P, msg.header.frame_id)


@dataclass(frozen=True)
class AisTruthEntry(StatusRecord):
    """Which ship (MMSI) a source's local track is, and how many reports of it the source makes."""

    KIND = 'AIS truth entry'

    mmsi: int
    reports: int

    def truth_status(self, track_id: str, hardware_id: str = '') -> DiagnosticStatus:
        """The status of local track ``track_id`` (``<prefix>/reports/<local id>``) in the truth table."""
        return self.to_status(track_id, DIAG_OK, 'evaluation only', hardware_id)

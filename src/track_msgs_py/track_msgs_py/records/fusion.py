"""Typed records of the fusion system: the pair score and the AIS truth table entry.

``FusionPairScore``: one status of ``/fusion/scores`` (and ``/fusion/associations``) per pair
of tracks at one instant, named ``"<track A> | <track B>"`` (``pair_name``), level OK, message
``associated`` / ``not associated``, hardware id ``fusion``. The fusion node writes it; the
fusion, ais and maritime summaries and the tests read it. Scores travel with 6 decimals.

``AisTruthEntry``: one status of ``<prefix>/truth`` per local track of an ``ais_source``, named
like the fusion node's track id ``<prefix>/reports/<local id>``, message ``evaluation only``:
the ship's MMSI and how many reports the source makes of it. Evaluation only: the fusion node
never reads it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Self

from diagnostic_msgs.msg import DiagnosticStatus

from track_msgs_py.records import DIAG_OK, RecordError, StatusRecord

PAIR_SEPARATOR = ' | '
_SIX = '{:.6f}'.format


def pair_name(a: str, b: str) -> str:
    """Status name of the pair of track ids (a, b)."""
    return f'{a}{PAIR_SEPARATOR}{b}'


def split_pair_name(name: str) -> tuple[str, str]:
    """(a, b) from a pair status name; ``RecordError`` when it names no pair."""
    a, sep, b = name.partition(PAIR_SEPARATOR)
    if not sep or not a or not b:
        raise RecordError(f'fusion pair score: status name {name!r} is not "<track> | <track>"')
    return a, b


@dataclass(frozen=True)
class FusionPairScore(StatusRecord):
    """Instant score, combined score of the window, instants in the window, verdict, method."""

    KIND = 'fusion pair score'

    score: float = field(metadata={'fmt': _SIX})
    combined: float = field(metadata={'fmt': _SIX})
    instants: int
    associated: bool
    method: str

    def pair_status(self, a: str, b: str, hardware_id: str = 'fusion') -> DiagnosticStatus:
        """The status of pair (a, b) as the fusion node publishes it."""
        return self.to_status(pair_name(a, b), DIAG_OK, 'associated' if self.associated else 'not associated',
                              hardware_id)

    @classmethod
    def read(cls, status: DiagnosticStatus) -> tuple[tuple[str, str], Self]:
        """((a, b), record) of one status of /fusion/scores."""
        return split_pair_name(status.name), cls.from_status(status)


@dataclass(frozen=True)
class AisTruthEntry(StatusRecord):
    """Which ship (MMSI) a source's local track is, and how many reports of it the source makes."""

    KIND = 'AIS truth entry'

    mmsi: int
    reports: int

    def truth_status(self, track_id: str, hardware_id: str = '') -> DiagnosticStatus:
        """The status of local track ``track_id`` (``<prefix>/reports/<local id>``) in the truth table."""
        return self.to_status(track_id, DIAG_OK, 'evaluation only', hardware_id)

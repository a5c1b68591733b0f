"""A recognised maritime picture on real ships: the Solent AIS reports as truth (issue 8, part 2).

- :mod:`.reader` — :func:`read_ais`: the CSV with row validation (bad rows skipped and counted).
- :mod:`.projection` — :class:`LocalTangentPlane`: latitude/longitude → east/north metres in the
  WGS-84 tangent plane at the data centroid (accuracy documented there).
- :mod:`.sources` — :class:`ShipTruth` (interpolated AIS tracks), :class:`SourceModel` and
  :func:`simulate_source`: simulated report sources (coastal radar, patrol) with their own 2σ
  ellipses, rates, dropouts and local track ids; the MMSI is kept as truth only.
- :mod:`.association` — :class:`PairTable`: every cross-source pair scored at the common
  instants (batched geofeasibility scores), per-pair decisions (threshold, majority, one-to-one)
  and precision/recall/F1 against the MMSI.
- :mod:`.experiments` — ``track-experiment ais-association``.
"""

from track_core.ais.association import (
    Metrics,
    PairDecisions,
    PairInstants,
    PairTable,
    evaluate,
    match_one_to_one,
    pair_instants,
)
from track_core.ais.projection import LocalTangentPlane
from track_core.ais.reader import AisData, default_path, read_ais
from track_core.ais.sources import (
    PATROL,
    RADAR,
    ShipTruth,
    SourceModel,
    SourceReports,
    report_times,
    simulate_source,
)

__all__ = [
    'PATROL',
    'RADAR',
    'AisData',
    'LocalTangentPlane',
    'Metrics',
    'PairDecisions',
    'PairInstants',
    'PairTable',
    'ShipTruth',
    'SourceModel',
    'SourceReports',
    'default_path',
    'evaluate',
    'match_one_to_one',
    'pair_instants',
    'read_ais',
    'report_times',
    'simulate_source',
]

"""A recognised maritime picture on real ships: AIS reports as truth (any coast).

- :mod:`.reader` — :func:`read_ais`: any AIS CSV through a :class:`ColumnMap` (presets, COG/SOG
  from positions when absent) with row validation (bad rows skipped, counted, and loud past 2 %;
  the region radius derived from the data).
- :mod:`.projection` — :class:`LocalTangentPlane`: latitude/longitude → east/north metres in the
  WGS-84 tangent plane at the data centroid (accuracy documented there).
- :mod:`.sources` — :class:`ShipTruth` (interpolated AIS tracks, gap limits derived per ship),
  :class:`SourceModel` (sites relative to the traffic: :func:`resolve_site`) and
  :func:`simulate_source`: simulated report sources (coastal radar, patrol) with their own 2σ
  ellipses, rates, dropouts and local track ids; the MMSI is kept as truth only.
- :mod:`.association` — :class:`PairTable`: every cross-source pair scored at the common
  instants (batched geofeasibility scores), per-pair decisions (threshold, majority or the
  short-pair prior :func:`declare`, one-to-one) and precision/recall/F1 against the MMSI;
  :func:`pair_tables` and :class:`StreamingDecisions` do the same in time chunks (bounded memory).
- :mod:`.synthetic` — a seeded synthetic AIS file of another sea (long report intervals, a
  large spread, planted defects) in any column layout.
"""

from track_core.ais.association import (
    Metrics,
    PairDecisions,
    PairInstants,
    PairTable,
    StreamingDecisions,
    declare,
    evaluate,
    match_one_to_one,
    pair_instants,
    pair_tables,
)
from track_core.ais.projection import LocalTangentPlane
from track_core.ais.reader import PRESETS, AisData, ColumnMap, default_path, read_ais
from track_core.ais.sources import (
    PATROL,
    RADAR,
    ShipTruth,
    SourceModel,
    SourceReports,
    report_times,
    resolve_site,
    simulate_source,
)

__all__ = [
    'PATROL',
    'PRESETS',
    'RADAR',
    'AisData',
    'ColumnMap',
    'LocalTangentPlane',
    'Metrics',
    'PairDecisions',
    'PairInstants',
    'PairTable',
    'ShipTruth',
    'SourceModel',
    'SourceReports',
    'StreamingDecisions',
    'declare',
    'default_path',
    'evaluate',
    'match_one_to_one',
    'pair_instants',
    'pair_tables',
    'read_ais',
    'report_times',
    'resolve_site',
    'simulate_source',
]

"""Track-to-track fusion support: a table of the latest report per track, brought to a common
instant (``TrackTable``), the scoring instants taken from the reports' stamps (``StampSchedule``),
and the pair associator that scores, combines and fuses every pair of tracks (``PairAssociator``,
what the ``fusion`` node runs, configured by ``AssociatorConfig``; geofeasibility scores live in
``track_core.geofeasibility``, covariance intersection in ``filters``)."""

from track_core.fusion.associator import FusedPair, Instant, PairAssociator, PairScore
from track_core.fusion.config import AssociatorConfig
from track_core.fusion.schedule import StampSchedule
from track_core.fusion.tracks import TrackReport, TrackTable

__all__ = ['AssociatorConfig', 'FusedPair', 'Instant', 'PairAssociator', 'PairScore', 'StampSchedule', 'TrackReport',
           'TrackTable']

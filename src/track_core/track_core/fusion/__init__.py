"""Track-to-track fusion support: a table of the latest report per track, brought to a common
instant, the scoring instants taken from the reports' stamps (``StampSchedule``), and the per-pair
score history that the ``fusion`` node combines (geofeasibility scores live in
``track_core.geofeasibility``, covariance intersection in ``filters``)."""

from track_core.fusion.schedule import StampSchedule
from track_core.fusion.tracks import TrackReport, TrackTable

__all__ = ['StampSchedule', 'TrackReport', 'TrackTable']

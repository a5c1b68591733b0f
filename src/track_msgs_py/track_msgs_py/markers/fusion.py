"""Markers of the fusion node (``/fusion/markers``): a 2σ ellipse per track, a link per scored pair.

Each track keeps one marker id for the whole run (the order in which tracks were first drawn),
so RViz/Foxglove replace a track's ellipse instead of stacking them; an ellipse lives two scoring
periods, so a track that drops out disappears. Links are one LINE_LIST, coloured red → green by the
pair's combined score.
"""

from __future__ import annotations

from geometry_msgs.msg import Point
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from track_core.fusion import Instant
from track_msgs_py.markers.ellipses import covariance_ellipse_markers
from track_msgs_py.stamps import sec_to_stamp
from track_msgs_py.topics import FRAME_MAP

TRACKS_NS, LINKS_NS = 'fusion_tracks', 'fusion_links'


class FusionMarkers:
    """Builds the MarkerArray of one scored instant; remembers each track's marker id."""

    def __init__(self, lifetime: float, frame_id: str = FRAME_MAP) -> None:
        self.lifetime, self.frame_id = lifetime, frame_id
        self.marker_ids: dict[str, int] = {}

    def build(self, instant: Instant, pairs=None) -> MarkerArray:
        """Ellipses of every track, links of ``pairs`` (default: every pair of the instant)."""
        t, mu = instant.t, instant.mu
        out = MarkerArray()
        mids = [self.marker_ids.setdefault(track_id, len(self.marker_ids)) for track_id in instant.ids]
        out.markers += covariance_ellipse_markers(t, mu, instant.R, self.frame_id, ns=TRACKS_NS, marker_ids=mids,
                                                  lifetime=self.lifetime)
        link = Marker(ns=LINKS_NS, id=0, type=Marker.LINE_LIST, action=Marker.ADD)
        link.header.stamp, link.header.frame_id = sec_to_stamp(t), self.frame_id
        link.scale.x = 0.5
        link.pose.orientation.w = 1.0
        for q in instant.pairs if pairs is None else pairs:
            c = ColorRGBA(r=float(1.0 - q.combined), g=float(q.combined), b=0.0, a=1.0)
            link.points += [Point(x=float(mu[q.ia][0]), y=float(mu[q.ia][1])),
                            Point(x=float(mu[q.ib][0]), y=float(mu[q.ib][1]))]
            link.colors += [c, c]
        out.markers.append(link)
        return out

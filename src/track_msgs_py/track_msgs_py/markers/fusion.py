"""Markers of the fusion node (``/fusion/markers``): a 2σ ellipse per track, a dot per fused pair, a link per pair.

An ellipse is one flat ``CYLINDER`` marker scaled to the 2σ axes and turned to the major axis
(``geofeasibility.ellipse.gaussian_to_ellipse``, vectorised over tracks): no outline points, so a
picture of 1000 tracks costs 1000 small markers instead of tens of thousands of ``Point`` objects,
and RViz and Foxglove draw it the same. Each track keeps one marker id for the whole run (the order
in which tracks were first drawn), so the viewers replace a track's ellipse instead of stacking
them; an ellipse lives ``lifetime`` seconds, so a track that drops out disappears. Fused pairs are
one ``SPHERE_LIST`` of green dots; links are one ``LINE_LIST`` per band of combined score, coloured
red → green (a colour per band, not per vertex: half the objects to build and serialize).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from builtin_interfaces.msg import Duration
from geometry_msgs.msg import Point
from std_msgs.msg import ColorRGBA, Header
from visualization_msgs.msg import Marker, MarkerArray

from track_core.geofeasibility.ellipse import gaussian_to_ellipse
from track_msgs_py.stamps import sec_to_stamp
from track_msgs_py.topics import FRAME_MAP

TRACKS_NS, FUSED_NS, LINKS_NS = 'fusion_tracks', 'fusion_fused', 'fusion_links'
THICKNESS = 0.2  # m: the discs' height
TRACK_RGBA, FUSED_RGBA = (1.0, 0.55, 0.0, 0.35), (0.1, 0.9, 0.2, 1.0)
FUSED_DOT, LINK_WIDTH = 4.0, 0.5   # m: a fused pair's dot, a link's width
LINK_BANDS = 5                     # links drawn per band of combined score, one colour each


def ellipse_discs(header: Header, mu: np.ndarray, R: np.ndarray, ns: str, ids: Sequence[int],
                  rgba: Sequence[float], lifetime: Duration, cache: dict | None = None) -> list[Marker]:
    """Flat cylinders of the 2σ ellipses of (μ (n, 2), R (n, 2, 2)), marker ids ``ids``.

    ``cache`` ((ns, id) → Marker) reuses the markers of earlier calls: building a ``Marker`` costs
    about 30 times setting its pose and scale, and a published message may be changed afterwards
    (``publish`` serializes it at once).
    """
    if not len(ids):
        return []
    mu, R = np.asarray(mu, float).reshape(-1, 2), np.asarray(R, float).reshape(-1, 2, 2)
    x, y, rx, ry, phi = gaussian_to_ellipse(mu, R)
    yaw = 0.5 * np.pi - phi                      # φ: bearing clockwise from north → yaw from +x
    qz, qw = np.sin(0.5 * yaw), np.cos(0.5 * yaw)
    color = ColorRGBA(r=float(rgba[0]), g=float(rgba[1]), b=float(rgba[2]), a=float(rgba[3]))
    out = []
    for mid, px, py, sx, sy, z, w in zip(ids, x.tolist(), y.tolist(), (2 * rx).tolist(), (2 * ry).tolist(),
                                         qz.tolist(), qw.tolist(), strict=True):
        m = None if cache is None else cache.get((ns, mid))
        if m is None:
            m = Marker(ns=ns, id=int(mid), type=Marker.CYLINDER, action=Marker.ADD, color=color)
            if cache is not None:
                cache[(ns, mid)] = m
        m.header, m.lifetime = header, lifetime
        m.pose.position.x, m.pose.position.y = px, py
        m.pose.orientation.z, m.pose.orientation.w = z, w
        m.scale.x, m.scale.y, m.scale.z = max(sx, 1e-3), max(sy, 1e-3), THICKNESS
        out.append(m)
    return out


class FusionMarkers:
    """Builds the MarkerArray of one scored instant; remembers each track's marker id."""

    def __init__(self, lifetime: float, frame_id: str = FRAME_MAP) -> None:
        self.lifetime, self.frame_id = lifetime, frame_id
        self.marker_ids: dict[str, int] = {}
        self._cache: dict[tuple[str, int], Marker] = {}

    def build(self, instant, pairs=None) -> MarkerArray:
        """Ellipses of every track, dots of the fused pairs, links of ``pairs`` (default: the scored pairs)."""
        t, mu = instant.t, instant.mu
        stamp, life = sec_to_stamp(t), sec_to_stamp(self.lifetime)
        header = Header(stamp=stamp, frame_id=self.frame_id)
        lifetime = Duration(sec=life.sec, nanosec=life.nanosec)
        mids = [self.marker_ids.setdefault(track_id, len(self.marker_ids)) for track_id in instant.ids]
        out = MarkerArray()
        out.markers = ellipse_discs(header, mu, instant.R, TRACKS_NS, mids, TRACK_RGBA, lifetime, self._cache)
        fused = np.array([f.mu for f in instant.fused], float).reshape(-1, 2)
        dots = _marker(header, FUSED_NS, 0, Marker.SPHERE_LIST, FUSED_RGBA, lifetime, FUSED_DOT)
        dots.points = [Point(x=x, y=y) for x, y in fused.tolist()]
        out.markers.append(dots)
        out.markers += self._links(header, mu, instant.pairs if pairs is None else pairs, lifetime)
        return out

    @staticmethod
    def _links(header: Header, mu: np.ndarray, pairs, lifetime: Duration) -> list[Marker]:
        """One LINE_LIST per band of combined score (``LINK_BANDS``), coloured red → green by the band's middle."""
        ia = pairs.ia if hasattr(pairs, 'ia') else np.array([q.ia for q in pairs], np.intp)
        ib = pairs.ib if hasattr(pairs, 'ib') else np.array([q.ib for q in pairs], np.intp)
        c = pairs.combined if hasattr(pairs, 'combined') else np.array([q.combined for q in pairs], float)
        band = np.minimum((np.asarray(c, float) * LINK_BANDS).astype(int), LINK_BANDS - 1)
        out = []
        for k in range(LINK_BANDS):
            v = (k + 0.5) / LINK_BANDS
            link = _marker(header, LINKS_NS, k, Marker.LINE_LIST, (1.0 - v, v, 0.0, 1.0), lifetime, LINK_WIDTH)
            sel = np.flatnonzero(band == k)
            ends = np.stack([mu[ia[sel]], mu[ib[sel]]], 1).reshape(-1, 2).tolist() if sel.size else []
            link.points = [Point(x=x, y=y) for x, y in ends]
            out.append(link)
        return out


def _marker(header: Header, ns: str, mid: int, kind: int, rgba: Sequence[float], lifetime: Duration,
            scale: float) -> Marker:
    m = Marker(header=header, ns=ns, id=mid, type=kind, action=Marker.ADD, lifetime=lifetime,
               color=ColorRGBA(r=float(rgba[0]), g=float(rgba[1]), b=float(rgba[2]), a=float(rgba[3])))
    m.pose.orientation.w = 1.0
    m.scale.x = m.scale.y = m.scale.z = float(scale)
    return m

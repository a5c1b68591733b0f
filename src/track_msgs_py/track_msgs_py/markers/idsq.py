"""Markers of the IDSQ network on ``/idsq/markers``: the sensors, the leader, the handoff link, the estimate."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from geometry_msgs.msg import Point
from std_msgs.msg import ColorRGBA, Header
from visualization_msgs.msg import Marker, MarkerArray

from track_msgs_py.markers.ellipses import covariance_ellipse_marker
from track_msgs_py.stamps import sec_to_stamp
from track_msgs_py.topics import FRAME_MAP

if TYPE_CHECKING:
    from track_core.idsq.network import SensorLayout  # only annotated: importing track_core.idsq loads scipy


def sensor_markers(t: float, layout: SensorLayout, leader: int, nxt: int | None, mean: np.ndarray,
                   cov: np.ndarray) -> MarkerArray:
    """Sensors (acoustic blue, DOA green), the leader (red), the link to the next leader, the 2σ ellipse."""
    header = Header(stamp=sec_to_stamp(t), frame_id=FRAME_MAP)
    pts = [Point(x=x, y=y) for x, y in layout.positions.tolist()]
    colours = [ColorRGBA(r=0.1, g=0.8, b=0.2, a=1.0) if d else ColorRGBA(r=0.2, g=0.4, b=1.0, a=1.0)
               for d in layout.is_doa.tolist()]
    sensors = Marker(header=header, ns='idsq_sensors', id=0, type=Marker.SPHERE_LIST, action=Marker.ADD,
                     points=pts, colors=colours)
    sensors.scale.x = sensors.scale.y = sensors.scale.z = 4.0
    lead = Marker(header=header, ns='idsq_leader', id=0, type=Marker.SPHERE, action=Marker.ADD,
                  color=ColorRGBA(r=1.0, g=0.1, b=0.1, a=0.9))
    lead.pose.position = Point(x=float(layout.positions[leader, 0]), y=float(layout.positions[leader, 1]))
    lead.scale.x = lead.scale.y = lead.scale.z = 8.0
    sensors.pose.orientation.w = lead.pose.orientation.w = 1.0
    markers = [sensors, lead]
    if nxt is not None and nxt != leader:
        link = Marker(header=header, ns='idsq_next', id=0, type=Marker.ARROW, action=Marker.ADD,
                      points=[pts[leader], pts[nxt]], color=ColorRGBA(r=1.0, g=0.6, b=0.0, a=1.0))
        link.pose.orientation.w = 1.0
        link.scale.x, link.scale.y, link.scale.z = 1.0, 3.0, 3.0
        markers.append(link)
    markers.append(covariance_ellipse_marker(t, mean, cov, FRAME_MAP, ns='idsq_estimate', line_width=1.0))
    return MarkerArray(markers=markers)

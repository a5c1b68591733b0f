"""Live AIS and the map datum ⇄ messages: the datum as a NavSatFix, a report as a TrackArray, ships as statuses.

- The map datum (lat0, lon0) → sensor_msgs/NavSatFix on ``map_datum`` (latched): ``header.stamp``
  when fixed, ``frame_id`` ``map``, ``latitude``/``longitude`` ← lat0/lon0, ``altitude`` 0,
  ``status.status`` STATUS_FIX, covariance unknown.
- One AIS report (``StateReport``) → TrackArray of one track: ``header`` ← report time, ``map``;
  ``id`` ← MMSI (decimal), ``source`` ← node name, x, vx, y, vy and the 4×4 covariance; velocity
  not estimated (0, variance 1e6) without SOG or COG.
- Ships' static data → DiagnosticArray on ``<prefix>/ships`` (latched): one status per MMSI,
  ``name`` ← MMSI, ``message`` ← ship name, values ``name``, ``ship_type``, ``callsign``,
  ``reports`` (Track.msg has no slot for them; a late subscriber gets the whole table).
- The map in the earth (``Datum.earth_pose``) → TransformStamped on ``/tf_static``: ``earth`` (ECEF,
  REP-105) → ``map``, the origin's ECEF point and its east, north, up axes.
- A GNSS position (input) ← NavSatFix: ``header.stamp`` → t; latitude/longitude → z through the
  datum; ``position_covariance`` (ENU, row-major) east/north block → R, turned by the meridian
  convergence; altitude and ``frame_id`` not read. Refused without a fix (``status.status`` <
  STATUS_FIX), with ``COVARIANCE_TYPE_UNKNOWN``, non-finite or out-of-range coordinates, or a
  covariance outside the ``InputPolicy`` bounds.
"""

from __future__ import annotations

import math

import numpy as np
from geometry_msgs.msg import TransformStamped
from sensor_msgs.msg import NavSatFix, NavSatStatus

from track_msgs_py.covariance import NOT_ESTIMATED_VARIANCE
from track_msgs_py.diagnostics import DIAG_OK, diagnostic_array, diagnostic_status
from track_msgs_py.stamps import sec_to_stamp, stamp_to_sec, stamped_header
from track_msgs_py.topics import FRAME_MAP
from track_msgs_py.track_arrays import tracks_to_array
from track_msgs_py.validate import DEFAULT_POLICY, InputPolicy, variance_problem

FRAME_EARTH = 'earth'   # REP-105's earth-centred, earth-fixed frame


def datum_to_navsatfix(t: float, lat0: float, lon0: float, frame_id: str = FRAME_MAP) -> NavSatFix:
    """The origin of ``frame_id`` on WGS-84 as a NavSatFix (table above)."""
    msg = NavSatFix(header=stamped_header(t, frame_id), latitude=float(lat0), longitude=float(lon0), altitude=0.0)
    msg.status.status = NavSatStatus.STATUS_FIX
    msg.status.service = NavSatStatus.SERVICE_GPS
    msg.position_covariance_type = NavSatFix.COVARIANCE_TYPE_UNKNOWN
    return msg


def navsatfix_problem(msg: NavSatFix) -> str | None:
    """Why a NavSatFix gives no position (no fix, non-finite or out-of-range latitude/longitude), else None."""
    if msg.status.status < NavSatStatus.STATUS_FIX:
        return f'status.status: {msg.status.status} (no fix)'
    lat, lon = msg.latitude, msg.longitude
    if not (math.isfinite(lat) and -90.0 < lat < 90.0):
        return f'latitude: {lat!r} is not in (-90, 90)'
    if not (math.isfinite(lon) and -180.0 <= lon <= 180.0):
        return f'longitude: {lon!r} is not in [-180, 180]'
    return None


def navsatfix_to_datum(msg: NavSatFix) -> tuple[float, float, float, str]:
    """(stamp [s], lat0, lon0, frame_id) of a datum message."""
    return stamp_to_sec(msg.header.stamp), float(msg.latitude), float(msg.longitude), msg.header.frame_id


def datum_to_transform(t: float, datum, frame_id: str = FRAME_MAP, earth: str = FRAME_EARTH) -> TransformStamped:
    """The pose of ``frame_id`` in ``earth`` (ECEF) for a ``track_core.ais.datum.Datum`` (table above)."""
    trans, q = datum.earth_pose()
    msg = TransformStamped(child_frame_id=frame_id)
    msg.header.stamp, msg.header.frame_id = sec_to_stamp(t), earth
    v, r = msg.transform.translation, msg.transform.rotation
    v.x, v.y, v.z = (float(c) for c in trans)
    r.x, r.y, r.z, r.w = (float(c) for c in q)
    return msg


def navsatfix_en_covariance(msg: NavSatFix) -> np.ndarray:
    """The east/north block (2, 2) of a NavSatFix's position covariance (ENU, row-major) [m²]."""
    c = np.asarray(msg.position_covariance, float).reshape(3, 3)
    return c[:2, :2]


def navsatfix_position_problem(msg: NavSatFix, policy: InputPolicy = DEFAULT_POLICY) -> str | None:
    """Why a NavSatFix is no usable position report (no fix, bad latitude/longitude, no covariance), else None."""
    reason = navsatfix_problem(msg)
    if reason is None and msg.position_covariance_type == NavSatFix.COVARIANCE_TYPE_UNKNOWN:
        reason = 'position_covariance_type: unknown (a position without an uncertainty cannot be scored)'
    if reason is None:
        reason = variance_problem('position_covariance', navsatfix_en_covariance(msg), policy)
    return reason


def navsatfix_to_position(msg: NavSatFix, datum) -> tuple[float, np.ndarray, np.ndarray]:
    """(t, z (2,), R (2, 2)) in map of a NavSatFix, through the run's ``Datum`` (table above)."""
    lat, lon = float(msg.latitude), float(msg.longitude)
    with np.errstate(invalid='ignore', over='ignore'):   # a fix a quarter of the globe away: inf, refused by bounds
        z = np.asarray(datum.forward(lat, lon), float)
        R = datum.to_map_covariance(lat, lon, navsatfix_en_covariance(msg))
    return stamp_to_sec(msg.header.stamp), z, 0.5 * (R + R.T)


def report_to_array(t: float, report, source: str, frame_id: str = FRAME_MAP):
    """One ``track_core.ais.live.StateReport`` at ``t`` → a TrackArray of one track, id = the MMSI."""
    x = np.zeros(4)
    P = np.zeros((4, 4))
    x[[0, 2]] = report.z
    P[np.ix_([0, 2], [0, 2])] = report.R
    if report.v is None:
        P[1, 1] = P[3, 3] = NOT_ESTIMATED_VARIANCE
    else:
        x[[1, 3]] = report.v
        P[np.ix_([1, 3], [1, 3])] = report.Pv
    return tracks_to_array(t, [str(report.mmsi)], [source], x[None], P[None], frame_id)


def ships_to_diagnostics(t: float, ships, hardware_id: str = ''):
    """Ships (``track_core.ais.live.Ship``) with static data → one DiagnosticArray (table above)."""
    return diagnostic_array(t, [
        diagnostic_status(str(s.mmsi), DIAG_OK, s.name, {'name': s.name, 'ship_type': s.ship_type,
                                                         'callsign': s.callsign, 'reports': s.reports},
                          hardware_id)
        for s in ships])

"""The run's one map datum as a node keeps it: latched on ``map_datum``, placed on ``/tf_static``.

Why one helper: every node that turns latitude/longitude into ``map`` metres (``ais_nmea_source``,
``ais_source``, ``fusion``'s NavSatFix inputs) must agree where ``map`` lies on the earth, and must
say so the same way. The rule is ``track_core.ais.datum.RunDatum``'s; this helper is its wiring:

- it listens on ``map_datum`` (``sensor_msgs/NavSatFix``, transient-local: a node started late
  still hears it) and reports what it hears: a datum taken (one line), a conflict (this node's own
  datum differs from the run's: one error line, and the node then refuses its input with that
  reason, naming both), or a different datum that is not the run's (published later, or heard
  once this node's datum has settled, ``RunDatum``): refused through ``TrackNode.refuse``, so a
  stray or hostile datum costs a throttled line and changes nothing;
- a node that fixes the datum (its ``origin`` parameter, its data, or its first fix) publishes it
  there, and places ``map`` in REP-105's ``earth`` (ECEF) frame on ``/tf_static``
  (``earth`` → ``map``, ``track_msgs_py.ais.datum_to_transform``), the link ``navsat_transform``
  publishes as ``utm`` → ``map``: a viewer or another tool can put the map on a globe, and a bag
  records where its ``map`` is.

A bad datum message (no fix, a latitude out of range) is refused through ``TrackNode.refuse``.
"""

from __future__ import annotations

from sensor_msgs.msg import NavSatFix

from track_core.ais.datum import Datum, RunDatum
from track_msgs_py.ais import datum_to_navsatfix, datum_to_transform, navsatfix_problem, navsatfix_to_datum
from track_msgs_py.qos import STATIC_QOS
from track_msgs_py.topics import FRAME_MAP, MAP_DATUM


def latlon_param(name: str, value, unset_allowed: bool = False) -> tuple[float, float] | None:
    """A ``[lat, lon]`` parameter in degrees, checked (one ``ParameterError`` line); ``[0.0]`` is None (unset)
    when ``unset_allowed``."""
    from track_nodes.base import ParameterError

    v = [float(x) for x in value]
    if unset_allowed and v == [0.0]:
        return None
    if len(v) != 2 or not (-90.0 <= v[0] <= 90.0 and -180.0 <= v[1] <= 180.0):
        raise ParameterError(f'parameter {name}={list(value)} is invalid: allowed [lat, lon] in degrees'
                             + (' or [0.0]' if unset_allowed else ''))
    return v[0], v[1]


class MapDatumLink:
    """A node's end of the run's datum: ``run`` (the rule), the latched topic and the earth → map transform."""

    def __init__(self, node, origin: tuple[float, float] | None = None, *, fallback: bool = False,
                 publish: bool = True, frame_id: str = FRAME_MAP) -> None:
        self.node, self.frame_id = node, frame_id
        self.run = RunDatum(origin, fallback=fallback)
        self.where = node.resolved(MAP_DATUM)
        self.pub = node.create_publisher(NavSatFix, MAP_DATUM, STATIC_QOS) if publish else None
        self.sub = node.create_subscription(NavSatFix, MAP_DATUM, self._on_datum, STATIC_QOS)

    @property
    def datum(self) -> Datum | None:
        return self.run.datum

    @property
    def conflict(self) -> str | None:
        return self.run.conflict

    def problem(self) -> str | None:
        """Why a latitude/longitude cannot go into map now (a conflict, no datum yet), else None."""
        reason = self.run.problem()
        if reason is not None and self.run.datum is None:
            return f'datum: no map datum known yet (none on {self.where})'
        return reason

    def fix(self, lat: float, lon: float) -> Datum:
        """This node fixes the run's datum: published on map_datum and as earth → map on /tf_static."""
        t = self.node.get_clock().now().nanoseconds * 1e-9
        datum = self.run.fix(lat, lon, t, self.node.steady_now())
        self._publish(t, datum)
        return datum

    def fix_own(self) -> Datum | None:
        """Fix and publish this node's ``origin`` when no datum is known yet (else nothing)."""
        if self.run.datum is None and self.run.origin is not None:
            return self.fix(*self.run.origin)
        return None

    def _publish(self, t: float, datum: Datum) -> None:
        if self.pub is None:
            return
        self.pub.publish(datum_to_navsatfix(t, datum.lat0, datum.lon0, self.frame_id))
        self.node.add_static_transforms(datum_to_transform(t, datum, self.frame_id))
        self.node.get_logger().info(f'map datum {datum.describe()} published on {self.where} '
                                    f'(and earth -> {self.frame_id} on /tf_static)')

    def _on_datum(self, msg: NavSatFix) -> None:
        reason = navsatfix_problem(msg)
        if reason:
            self.node.refuse(MAP_DATUM, reason)
            return
        t, lat, lon, _ = navsatfix_to_datum(msg)
        event, line = self.run.hear(t, lat, lon, self.where, self.node.steady_now())
        if event == 'refused':
            self.node.refuse(MAP_DATUM, line)
        elif event == 'conflict' and line is not None:
            self.node.get_logger().error(line)
        elif event == 'taken':
            self.node.get_logger().info(line)

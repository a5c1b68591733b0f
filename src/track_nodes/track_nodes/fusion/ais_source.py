"""``ais_source``: one simulated surveillance source observing the real Solent AIS ships, on /clock.

At start the node reads the AIS file (``file``; default the Solent file; bad rows skipped, counted,
logged in one line; ``columns`` maps another export), projects it through the run's map datum
(``track_core.ais.datum``: transverse Mercator, PROJ) and simulates this source's reports
(``track_core.ais.sources``) for data time [``start``, ``start`` + ``duration``] after the first
report. The first timer tick is data time ``start``: a report of data time τ is stamped origin + τ −
``start`` and published when the node clock reaches it (as fast as ``/clock``).

Reports at ``offset + k·period`` (node time), each missing with probability ``dropout``: the true
position plus Gaussian noise with its 2σ ellipse (1σ ``sigma_major`` × ``sigma_minor``;
``orientation`` ``fixed`` at ``bearing_deg``, ``radial`` from ``site`` (``[0.0]``: on the traffic's
hull at ``site_bearing_deg``) or ``random``); ships beyond ``max_range`` (0: none) unseen;
``max_gap`` 0 derives each ship's gap limit. With ``offset`` 4.5 s, ``period`` 5 s a fusion node
ticking every 5 s with ``stale_after`` 1 s scores exactly the reports 0.5 s before each tick.

Topics (``prefix`` e.g. ``/ais/radar``): ``<prefix>/reports`` (TrackArray in ``map``, one per
instant, local ids ``id_prefix`` + 3 digits, velocity not estimated; the MMSI never sent),
``<prefix>/markers`` (2σ discs and labels), ``<prefix>/truth`` (with ``publish_truth``:
DiagnosticArray, transient-local, once, ``mmsi`` and ``reports`` per ``<prefix>/reports/<local
id>``).

Datum (``track_nodes.fusion.map_datum``): ``origin`` [lat, lon] is this node's; one latched on
``map_datum`` that differs is a conflict (every instant refused, naming both). ``[0.0]``: the run's
datum if heard before the first report, else the data centroid, then published on ``map_datum`` and
as ``earth`` → ``map`` on ``/tf_static``. In full: docs/MODULES.md, "The ais_source node in full".
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from visualization_msgs.msg import MarkerArray

from track_core.ais import ShipTruth, SourceModel, read_ais, simulate_source
from track_core.ais.datum import Datum
from track_core.ais.sources import ORIENTATIONS
from track_msgs.msg import TrackArray
from track_msgs_py.diagnostics import diagnostic_array
from track_msgs_py.markers.tracks import TrackMarkers
from track_msgs_py.qos import ESTIMATE_QOS, STATIC_QOS
from track_msgs_py.records.fusion import AisTruthEntry
from track_msgs_py.topics import FRAME_MAP, ais_markers_topic, ais_reports_topic, ais_truth_topic
from track_msgs_py.track_arrays import position_tracks, tracks_to_array
from track_nodes.base import FixedRateSteps, ParameterError, TrackNode, param
from track_nodes.fusion.map_datum import MapDatumLink, latlon_param


@dataclass
class AisSourceParams:
    """Parameters of ``ais_source``."""

    file: str = param('', 'AIS CSV file (empty: the Solent file in the shared data folder)')
    columns: str = param('', 'column mapping: a preset or "time=...;mmsi=...;lat=...;lon=..." (empty: detect; '
        'see track_core.ais.reader)')
    start: float = param(0.0, 'data time replayed at node time 0 [s after the first AIS report]', 0.0, 1e7)
    duration: float = param(600.0, 'length of the replayed data window [s]', 1.0, 1e7)
    origin: list[float] = param([0.0], 'map datum [lat, lon] in degrees; [0.0]: the one on map_datum when heard '
                                'before the first report, else the data centroid (median)')
    max_gap: float = param(0.0, 'a ship is unknown inside a gap between its AIS reports longer than this [s]; '
        '0: derived per ship from its report interval', 0.0, 1e6)
    period: float = param(5.0, 'report interval [s]', 1e-3, 3600.0)
    offset: float = param(0.0, 'stamp of the first report [s]; reports at offset + k·period', 0.0, 3600.0)
    tick: float = param(0.5, 'publishing timer period [s]: a report goes out at the first tick at or after its stamp',
                        1e-3, 60.0)
    sigma_major: float = param(15.0, '1σ error along the major axis of the report ellipse [m]', 1e-3, 1e6)
    sigma_minor: float = param(8.0, '1σ error along the minor axis [m]', 1e-3, 1e6)
    orientation: str = param('radial', 'major-axis bearing: fixed | radial (across the line of sight from site) | '
        'random (per report)', choices=ORIENTATIONS)
    bearing_deg: float = param(0.0, 'major-axis bearing for orientation fixed, clockwise from north [deg]',
                               -360.0, 360.0)
    site: list[float] = param([0.0], 'sensor position [lat, lon] in degrees (radial orientation, max_range); [0.0]: '
                              'on the convex hull of the traffic at site_bearing_deg from its mean position')
    site_bearing_deg: float = param(280.0, "bearing of the hull site from the traffic's mean position [deg from north]",
                                    -360.0, 360.0)
    max_range: float = param(0.0, 'ships further than this from the site are not seen [m]; 0: no limit', 0.0, 1e7)
    dropout: float = param(0.02, 'probability that a report is missing', 0.0, 0.99)
    seed: int = param(1, 'seed of this source\'s noise, dropouts and local ids', 0, 2**31 - 1)
    id_prefix: str = param('r', 'local track ids are <id_prefix><3 digits>')
    prefix: str = param('/ais/radar', 'topic prefix: reports on <prefix>/reports, truth on <prefix>/truth')
    publish_truth: bool = param(True, 'publish the local track → MMSI table on <prefix>/truth (evaluation only)')
    marker_rgba: list[float] = param([0.0, 0.6, 1.0, 0.5], 'colour [r, g, b, a] of the 2σ discs on <prefix>/markers')


class AisSourceNode(TrackNode):
    DEFAULT_NAME = 'ais_source'
    Params = AisSourceParams
    p: AisSourceParams  # the declared parameters (base/params.py)

    def setup(self) -> None:
        p = self.p
        if p.sigma_minor > p.sigma_major:
            raise ParameterError(f'parameter sigma_minor={p.sigma_minor} exceeds sigma_major={p.sigma_major}')
        if not p.id_prefix or '#' in p.id_prefix or '/' in p.id_prefix:
            raise ParameterError(f'parameter id_prefix={p.id_prefix!r} is invalid: allowed a non-empty name without '
                             '"#" or "/"')
        data = read_ais(p.file or None, columns=p.columns or None)
        if data.n_skipped:
            self.get_logger().warning(f'AIS file {data.path}: {data.describe()}')
        else:
            self.get_logger().info(f'AIS file {data.path}: {data.describe()}')
        for line in data.warnings:
            self.get_logger().warning(line)
        centroid = list(p.origin) == [0.0]
        origin = data.centroid() if centroid else latlon_param('origin', p.origin)
        self.data = data
        self.model = SourceModel(name=self.get_name(), id_prefix=p.id_prefix, period=p.period, offset=p.offset,
                                 sigma_major=p.sigma_major, sigma_minor=p.sigma_minor, orientation=p.orientation,
                                 bearing_deg=p.bearing_deg,
                                 site=(f'hull:{p.site_bearing_deg:g}' if list(p.site) == [0.0]
                                       else latlon_param('site', p.site)),
                                 max_range=p.max_range or None, dropout=p.dropout)
        try:
            self._simulate(Datum(*origin))
        except ValueError as exc:  # a file reaching further than one projection holds (projection.py)
            raise ParameterError(f'parameter file={p.file!r}: {exc}') from None
        rep = self.reports
        self.next = 0
        self.map_datum = MapDatumLink(self, origin, fallback=centroid)
        self.datum_problem: str | None = None
        rgba = [float(c) for c in p.marker_rgba]
        if len(rgba) != 4 or not all(0.0 <= c <= 1.0 for c in rgba):
            raise ParameterError(f'parameter marker_rgba={list(p.marker_rgba)} is invalid: allowed [r, g, b, a] '
                                 'in [0, 1]')
        self.markers = TrackMarkers(p.id_prefix, 2.0 * p.period, rgba)
        self.topic = ais_reports_topic(p.prefix)
        self.pub = self.create_publisher(TrackArray, self.topic, ESTIMATE_QOS)
        self.pub_markers = self.create_publisher(MarkerArray, ais_markers_topic(p.prefix), ESTIMATE_QOS)
        self.get_logger().info(f'{len(rep.ids)} ships, {len(rep)} reports in [{p.start:g}, {p.start + p.duration:g}] s '
                               f'of data on {self.topic}')
        if p.publish_truth:
            self.pub_truth = self.create_publisher(DiagnosticArray, ais_truth_topic(p.prefix), STATIC_QOS)
        self.steps = FixedRateSteps(self, p.tick, self._step, max_time=p.duration, on_origin=self._publish_truth)

    def _simulate(self, datum: Datum) -> None:
        """This source's reports of the ships projected through ``datum`` (same seed: the same noise draws)."""
        p = self.p
        truth = ShipTruth(self.data, datum, max_gap=p.max_gap or None)
        if p.start >= truth.t_end:
            raise ParameterError(f'parameter start={p.start} is after the end of the data ({truth.t_end:.0f} s)')
        self.sim_datum = datum
        self.reports = simulate_source(truth, self.model, np.random.default_rng(p.seed), p.start,
                                       p.start + p.duration)
        self.stamps = self.reports.t - p.start

    def _check_datum(self) -> str | None:
        """Before a report goes out: the run's datum fixed (ours, when none was heard), the reports about it."""
        link = self.map_datum
        if link.datum is None:
            link.fix_own()
        reason = link.problem() or self.datum_problem
        if reason is None and not link.datum.same_as(self.sim_datum.lat0, self.sim_datum.lon0):
            if self.next:    # reports already out about the other datum: keep them apart (RunDatum)
                reason = self.datum_problem = (f'datum: the reports are projected about {self.sim_datum.describe()}, '
                                               f'not the run\'s {link.datum.describe()}')
            else:
                try:
                    self._simulate(link.datum)
                    self.get_logger().info(f'reports projected about the run\'s map datum {link.datum.describe()}')
                    self._publish_truth(self.steps.origin or 0.0)    # the local ids of the new reports
                except ValueError as exc:
                    reason = self.datum_problem = f'datum: the run\'s {link.datum.describe()}: {exc}'
        return reason

    def _publish_truth(self, origin: float) -> None:
        """The local track → MMSI table, once, stamped at the origin (the whole second of the first clock reading)."""
        if not self.p.publish_truth:
            return
        rep = self.reports
        counts = np.bincount(rep.track, minlength=len(rep.ids))
        self.pub_truth.publish(diagnostic_array(origin, [
            AisTruthEntry(int(rep.mmsi[k]), int(counts[k])).truth_status(f'{self.topic}/{tid}', self.get_name())
            for k, tid in enumerate(rep.ids)]))

    def _step(self, t: float) -> None:
        # node time = origin + (data time − start); the origin is the whole second of node time at the first tick
        origin = self.steps.origin or 0.0
        rep, k = self.reports, self.next
        while k < len(rep) and origin + self.stamps[k] <= t + 1e-9:
            reason = self._check_datum()
            rep = self.reports            # re-simulated about the run's datum before the first report
            end = k + 1
            while end < len(rep) and self.stamps[end] == self.stamps[k]:   # one array per report instant
                end += 1
            if reason is None:
                self._publish(origin + float(self.stamps[k]), slice(k, end))
            else:
                self.refuse(self.topic, reason)
            k = end
        self.next = k

    def _publish(self, stamp: float, sel: slice) -> None:
        rep = self.reports
        ids = [rep.ids[i] for i in rep.track[sel].tolist()]
        x, P = position_tracks(rep.mu[sel], rep.R[sel])
        self.pub.publish(tracks_to_array(stamp, ids, [self.get_name()] * len(ids), x, P, FRAME_MAP))
        self.pub_markers.publish(self.markers.build(stamp, ids, rep.mu[sel], rep.R[sel]))

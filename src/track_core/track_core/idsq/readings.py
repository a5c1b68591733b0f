"""The readings of the IDSQ field: what one sensor's front end gives for one step, and the §5.1 simulator.

A sensor node never sees the truth. Its front end (a microphone's amplitude detector, a DOA array's
beamformer), or the simulator standing in for it, gives one reading per step:

- ``amplitude``: the measured amplitude z of eq. 5 (z = A/‖x − ζ‖ + w). Every sensor has one: a DOA
  array is also a set of microphones, and the §5.1 start rule compares the step-0 amplitudes.
- ``bearing`` (DOA only): the direction to the source, the paper's θ of eq. 11, clockwise from north
  (``models.bearings``). On the wire (``track_msgs/IdsqReading``) it travels as a REP-103 direction,
  counter-clockwise from the frame's x axis (east): ``direction_of_bearing`` and
  ``bearing_of_direction`` convert at that boundary, both wrapped to (−π, π]. The two conversions are
  not exact inverses in floating point: about one DOA reading in five comes back one ulp (≤ 4.4e-16
  rad) off, so everything that must equal what a node computed (``leader_protocol.protocol_track``,
  ``track_nodes.report.network_replay``) uses ``as_received`` for the bearing, as the handoff's
  float32 body is used with ``decode_handoff``.

The simulator (§5.1): ``sensor_reading`` draws one standard normal per (seed, sensor, step) from
``SeedSequence(seed, spawn_key=(3, sensor, step))`` (``measurement_normal``): the same counter-based
draw the sensor nodes made when they simulated their own readings, so the readings, hence the
tracks, did not change when the simulation moved out of them. The amplitude and (for a DOA sensor)
the bearing of one reading share that normal, as they did: the bearing is what a DOA leader uses and
the amplitude only the start rule (at step 0, where only acoustic sensors can win), so no step
uses both. ``FieldSimulator`` holds the sources' truths per step (several topics, one or more
sources each: the maritime target and decoy) until every topic has delivered the step, then gives
every sensor's reading; each sensor hears its loudest (nearest) source (``models.loudest_source``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from track_core.filters import wrap_angle
from track_core.idsq.models import SimNoise, amplitude_reading, loudest_source, simulate_measurement
from track_core.idsq.network import SensorLayout

MEASUREMENT_KEY = 3  # spawn_key[0] of the measurement draws (keys 0-2: the core experiments', 4: selection)
MAX_PENDING = 4096  # incomplete truth steps the simulator holds (an absurd stamp is a huge step)


def measurement_normal(seed: int, sensor: int, step: int) -> float:
    """The standard normal of sensor ``sensor``'s reading at ``step`` (independent of process layout)."""
    ss = np.random.SeedSequence(int(seed), spawn_key=(MEASUREMENT_KEY, int(sensor), int(step)))
    return float(np.random.default_rng(ss).standard_normal())


def direction_of_bearing(theta: float) -> float:
    """REP-103 direction (counter-clockwise from east) of the paper's bearing θ (clockwise from north)."""
    return float(wrap_angle(np.pi / 2 - float(theta)))


def bearing_of_direction(direction: float) -> float:
    """The paper's bearing θ (eq. 11: clockwise from north) of a REP-103 direction (counter-clockwise from east)."""
    return float(wrap_angle(np.pi / 2 - float(direction)))


def as_received(theta: float) -> float:
    """θ after the message's round trip (``direction_of_bearing`` then ``bearing_of_direction``)."""
    return bearing_of_direction(direction_of_bearing(theta))


@dataclass(frozen=True)
class Reading:
    """One sensor's reading of one step: amplitude (every sensor) and, for a DOA sensor, the bearing θ
    (clockwise from north, eq. 11) with its standard deviation; NaN where the sensor has none."""

    step: int
    sensor: int
    is_doa: bool
    amplitude: float
    bearing: float = float('nan')
    bearing_std: float = float('nan')

    @property
    def z(self) -> float:
        """The measurement the sensor leads with: θ for a DOA sensor (eq. 11), the amplitude otherwise (eq. 6)."""
        return self.bearing if self.is_doa else self.amplitude


def sensor_reading(sources: np.ndarray, position: np.ndarray, is_doa: bool, sensor: int, step: int,
                   noise: SimNoise, seed: int) -> Reading:
    """§5.1 reading of sensor ``sensor`` at ``position`` for ``step``: it hears its loudest of ``sources``
    ((2,) or (M, 2)); one ``measurement_normal`` for both values (module docstring)."""
    pos = np.asarray(position, dtype=float)
    src = loudest_source(sources, pos)
    e = measurement_normal(seed, sensor, step)
    amp = amplitude_reading(src, pos, noise, e)
    if not is_doa:
        return Reading(int(step), int(sensor), False, amp)
    return Reading(int(step), int(sensor), True, amp, simulate_measurement(src, pos, True, noise, e), noise.sigma_doa)


def field_readings(sources: np.ndarray, layout: SensorLayout, step: int, noise: SimNoise, seed: int) -> list[Reading]:
    """Every sensor's ``sensor_reading`` of ``step`` (one per sensor: K draws of the counter-based keys)."""
    return [sensor_reading(sources, layout.positions[k], bool(layout.is_doa[k]), k, step, noise, seed)
            for k in range(layout.n)]


class FieldSimulator:
    """The readings of a field from the truths of its sources (``topics``: the truth streams' names).

    ``on_truth`` collects source ``child`` of ``topic`` at ``step``; once every topic has delivered the
    step it returns every sensor's reading of it (the sources in (topic, child) order; ties of
    loudness go to the first), else nothing. A step already given is not given again.
    """

    def __init__(self, layout: SensorLayout, noise: SimNoise, seed: int, topics: tuple[str, ...]) -> None:
        if not topics:
            raise ValueError('topics is empty: allowed one or more truth streams')
        self.layout, self.noise, self.seed, self.topics = layout, noise, int(seed), tuple(topics)
        self._sources: dict[int, dict[tuple[str, str], np.ndarray]] = {}
        self.done: set[int] = set()

    def on_truth(self, step: int, topic: str, child: str, xy: np.ndarray) -> list[Reading]:
        if step in self.done:
            return []
        got = self._sources.setdefault(step, {})
        got[(topic, child)] = np.asarray(xy, dtype=float)
        if not {tp for tp, _ in got} >= set(self.topics):
            while len(self._sources) > MAX_PENDING:
                del self._sources[min(self._sources)]
            return []
        del self._sources[step]
        self.done.add(step)
        if len(self.done) > MAX_PENDING:
            self.done.discard(min(self.done))
        sources = np.array([got[k] for k in sorted(got)])
        return field_readings(sources, self.layout, step, self.noise, self.seed)

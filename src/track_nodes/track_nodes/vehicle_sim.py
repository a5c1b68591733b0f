"""``vehicle_sim``: the §5.1 vehicle and sensor field of the IDSQ paper, as topics.

- At start it draws the sensor layout with the core's seeded §5.1 generator
  (``track_core.idsq.simulation.draw_run(Scenario(...), SeedSequence(seed)).layout``: K/4 rows ×
  4 columns over the field, jittered by N(0, ``jitter_var``), round(``doa_fraction``·K) DOA
  sensors) and publishes it once on ``/idsq/layout`` (transient-local, so sensors started later
  still get it): ``sensor_msgs/PointCloud2``, one point per sensor, FLOAT64 fields ``id``, ``x``,
  ``y``, ``type`` (0 acoustic, 1 DOA; ``track_msgs_py.convert.layout_to_pointcloud2``). The same
  seed gives the layout of the core experiments' run with that seed.
- Every Δt of node time (``FixedRateSteps``) it publishes the vehicle truth of tracker step s on
  ``/idsq/vehicle/truth`` (``nav_msgs/Odometry``, zero covariance, velocity (0, speed),
  ``child_frame_id`` = ``vehicle_id``), stamped (s + 1)·Δt: the first tick comes one period after
  the clock origin, and the vehicle enters the field (x = W/2, y = 0) then. It stops when the
  vehicle leaves the field (``Scenario.n_steps``, 72 for §5.1) or after ``max_steps``.

With ``publish_truth:=false`` it publishes only the layout: the maritime scenario's sensors hear
other sources (``idsq_sensor``'s ``truth_topics``).

The sensors are separate nodes whose ``id``/``position``/``type`` parameters must match this
layout: ``scenario_yaml`` writes a launcher scenario with all of them from the same generator
(``config/idsq.yaml`` was written by it).
"""

from __future__ import annotations

import numpy as np
from nav_msgs.msg import Odometry
from rclpy.node import Node
from sensor_msgs.msg import PointCloud2

from track_core.idsq import SensorLayout, TrackerParams
from track_core.idsq.simulation import Scenario, draw_run
from track_msgs_py.convert import cv_state_to_odometry, layout_to_pointcloud2
from track_msgs_py.qos import STATIC_QOS, TRUTH_QOS
from track_msgs_py.topics import FRAME_MAP, IDSQ_LAYOUT, IDSQ_TRUTH
from track_nodes.node_util import FixedRateSteps, Param, declare_params, run_node

_SC = Scenario()
PARAMS = (
    Param('seed', 0, 'layout seed: draw_run(Scenario, SeedSequence(seed)).layout', 0, 2**31 - 1),
    Param('n_sensors', 24, 'K sensors on a K/4 × 4 grid (a multiple of 4, §5.1)', 8, 4096),
    Param('doa_fraction', 0.3, 'fraction of DOA sensors (Table 4: 30 %)', 0.0, 1.0),
    Param('width', _SC.width, 'field width, x (§5.1: 150 m) [m]', 1.0, 1e5),
    Param('height', _SC.height, 'field height, y; the vehicle drives south to north (§5.1: 250 m) [m]', 1.0, 1e5),
    Param('jitter_var', _SC.jitter_var, 'variance of the N(0, σ²) jitter of each sensor coordinate (§5.1: 25) [m²]',
          0.0, 1e6),
    Param('speed', _SC.speed, 'vehicle speed (§5.1: 7 m/s) [m/s]', 1e-3, 1e3),
    Param('dt', _SC.tracker.dt, 'tracker step Δt = truth period (§5.1: 0.5 s) [s]', 1e-3, 60.0),
    Param('max_steps', 0, 'stop after this many steps; 0 = when the vehicle leaves the field', 0, 10**7),
    Param('vehicle_id', 'vehicle', 'child_frame_id of the truth'),
    Param('publish_truth', True, 'publish the §5.1 vehicle; false: only the layout (the sensors then sense '
          'other sources, see idsq_sensor truth_topics)'),
)


def scenario_of(seed: int = 0, n_sensors: int = 24, doa_fraction: float = 0.3, width: float = _SC.width,
                height: float = _SC.height, jitter_var: float = _SC.jitter_var, speed: float = _SC.speed,
                dt: float = _SC.tracker.dt) -> tuple[Scenario, SensorLayout, np.ndarray]:
    """The core's §5.1 scenario, its seeded layout and the (T, 2) truth of every tracker step."""
    sc = Scenario(n_sensors=n_sensors, doa_fraction=doa_fraction, width=width, height=height,
                  jitter_var=jitter_var, speed=speed, tracker=TrackerParams(dt=dt))
    run = draw_run(sc, np.random.SeedSequence(seed))
    return sc, run.layout, run.truth


class VehicleSimNode(Node):
    DEFAULT_NAME = 'vehicle_sim'

    def __init__(self, *, node_name: str = DEFAULT_NAME, context=None, parameter_overrides=None,
                 cli_args=None) -> None:
        super().__init__(node_name, context=context, parameter_overrides=parameter_overrides, cli_args=cli_args)
        self.p = p = declare_params(self, PARAMS)
        self.scenario, self.layout, self.truth = scenario_of(p.seed, p.n_sensors, p.doa_fraction, p.width, p.height,
                                                             p.jitter_var, p.speed, p.dt)
        n = self.truth.shape[0] if p.max_steps == 0 else min(p.max_steps, self.truth.shape[0])
        self.n_steps = n
        self.published = 0
        self.pub_layout = self.create_publisher(PointCloud2, IDSQ_LAYOUT, STATIC_QOS)
        self.pub_truth = self.create_publisher(Odometry, IDSQ_TRUTH, TRUTH_QOS)
        self.pub_layout.publish(layout_to_pointcloud2(0.0, self.layout))
        self.steps = FixedRateSteps(self, p.dt, self._step, n * p.dt)
        self.get_logger().info(f'{self.layout.n} sensors ({int(self.layout.is_doa.sum())} DOA), '
                               f'{n} truth steps of {p.dt:g} s')

    def _step(self, t: float) -> None:
        s = self.steps.k - 1
        if s >= self.n_steps or not self.p.publish_truth:
            return
        x, y = self.truth[s]
        state = np.array([x, 0.0, y, self.p.speed])
        self.pub_truth.publish(cv_state_to_odometry(t, state, np.zeros((4, 4)), FRAME_MAP, self.p.vehicle_id))
        self.published += 1


def scenario_yaml(seed: int = 0, n_sensors: int = 24, doa_fraction: float = 0.3, *, duration: float | None = None,
                  rate: float = 10.0, ack_timeout: float = 2.0, header: str = '') -> str:
    """A launcher scenario (``config/idsq.yaml`` layout) with vehicle_sim and one node per sensor.

    Sensor entries come from the same generator as vehicle_sim's layout; positions are written
    with ``repr`` so they parse back to the exact float64.
    """
    sc, layout, _ = scenario_of(seed, n_sensors, doa_fraction)
    if duration is None:
        duration = sc.n_steps * sc.tracker.dt + 1.0
    names = [f'sensor_{k}' for k in range(layout.n)]
    exes = ['doa_sensor' if d else 'acoustic_sensor' for d in layout.is_doa.tolist()]
    nodes = ', '.join(['vehicle_sim'] + [f'"{e}:{n}"' for e, n in zip(exes, names, strict=True)])
    lines = [header.rstrip()] if header else []
    lines += [
        'track_launch:',
        '  ros__parameters:',
        f'    nodes: [{nodes}]',
        '    record_regex: "^/idsq/"',
        '    summary: idsq',
        f'    duration: {float(duration)!r}',
        f'    rate: {float(rate)!r}',
        '',
        '/**:                        # shared by vehicle_sim and every sensor',
        '  ros__parameters:',
        f'    seed: {int(seed)}                  # layout (vehicle_sim) and measurement noise (sensors)',
        f'    width: {sc.width!r}',
        f'    height: {sc.height!r}',
        f'    dt: {sc.tracker.dt!r}',
        '    cell: 5.0',
        '    comm_range: 40.0',
        '    selection: mi             # mi | nearest | random',
        f'    ack_timeout: {float(ack_timeout)!r}          # wall seconds before a silent receiver is skipped',
        '',
        'vehicle_sim:',
        '  ros__parameters:',
        f'    n_sensors: {layout.n}',
        f'    doa_fraction: {float(doa_fraction)!r}',
        f'    speed: {sc.speed!r}',
    ]
    for k, (name, d) in enumerate(zip(names, layout.is_doa.tolist(), strict=True)):
        x, y = (float(v) for v in layout.positions[k])
        lines += ['', f'{name}:', '  ros__parameters:', f'    id: {k}', f'    position: [{x!r}, {y!r}]',
                  f'    type: {"doa" if d else "acoustic"}']
    return '\n'.join(lines) + '\n'


NODE_CLASS = VehicleSimNode


def main(argv=None) -> int:
    return run_node(VehicleSimNode, argv)


if __name__ == '__main__':
    raise SystemExit(main())

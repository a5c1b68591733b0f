"""Scenario files written from vehicle_sim's seeded sensor layout, so their sensor entries match it.

- ``idsq_yaml``: ``config/idsq.yaml`` (vehicle_sim and one node per sensor), and the IDSQ fields of
  any size that tests, the soak and ``idsq-field`` run;
- ``maritime_yaml``: ``config/maritime.yaml``; ``seed_scenario``: its variant of another seed
  (``maritime-seeds``).

The layout is the core's §5.1 generator (``track_core.idsq.simulation.scenario_of``), positions are
written with ``repr`` so they parse back to the exact float64. The shipped files are regenerated with
``python -c "from track_nodes.idsq.scenario_files import maritime_yaml as s; print(s(), end='')"``
(a test keeps ``config/maritime.yaml`` equal to it).
"""

from __future__ import annotations

import yaml

from track_core.idsq.simulation import scenario_of


def idsq_yaml(seed: int = 0, n_sensors: int = 24, doa_fraction: float = 0.3, *, duration: float | None = None,
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
        f'    seed: {int(seed)}                  # layout and readings (vehicle_sim), random selection (sensors)',
        f'    width: {sc.width!r}',
        f'    height: {sc.height!r}',
        f'    dt: {sc.tracker.dt!r}',
        '    cell: 5.0',
        '    comm_range: 40.0',
        '    selection: mi             # mi | nearest | random',
        f'    ack_timeout: {float(ack_timeout)!r}          # wall seconds before a silent receiver is skipped',
        '    reading_durability: transient_local  # a late sensor still gets vehicle_sim\'s step-0 readings',
        '',
        '/**/vehicle_sim:',
        '  ros__parameters:',
        f'    n_sensors: {layout.n}',
        f'    doa_fraction: {float(doa_fraction)!r}',
        f'    speed: {sc.speed!r}',
    ]
    for k, (name, d) in enumerate(zip(names, layout.is_doa.tolist(), strict=True)):
        x, y = (float(v) for v in layout.positions[k])
        lines += ['', f'/**/{name}:', '  ros__parameters:', f'    id: {k}', f'    position: [{x!r}, {y!r}]',
                  f'    type: {"doa" if d else "acoustic"}']
    return '\n'.join(lines) + '\n'


def maritime_yaml(*, seed: int = 1, n_sensors: int = 40, doa_fraction: float = 0.3, duration: float = 32.0,
                  rate: float = 20.0, dt: float = 1.0, grid_height: float = 300.0, comm_range: float = 60.0) -> str:
    """``config/maritime.yaml``: the fixed part below plus one entry per sensor of the seeded layout.

    The layout is ``vehicle_sim``'s (``scenario_of``, §5.1 generator, 150 × 250 m field), so the
    sensor entries agree with what vehicle_sim publishes. The sensors' belief grid reaches
    ``grid_height`` north (300 m): the smart target leaves the 250 m field at t ≈ 28 s, and a grid
    ending at the field edge would pin the belief there.

    ``comm_range`` (60 m, §5.1: 40 m): the layout's columns are W/4 = 37.5 m apart and every
    coordinate is jittered by N(0, 25 m²), so two sensors of one row in adjacent columns are within
    40 m with probability 0.60 only (19-22 of the 30 such links on seeds 1-5), and the leader cannot
    cross a missing link: on seed 5 the start leader sits west of such a gap and the network leads
    from sensors 39-88 m from the target for 11 s (RTAMS 16 m). 60 m is the 99.9 % quantile of that
    distance (59.9 m), so the neighbourhoods span the columns; the paper's 40 m stays the default of
    the nodes, ``config/idsq.yaml`` and the §5.1 experiments.

    ``ack_timeout`` 10 s (the nodes' default: 2 s): under ``ros2 launch`` the 40 sensors share one
    process, and on a busy machine an ack that took over 2 s made the leader re-select, so the track
    differed from the lock-step run; no sensor of this scenario fails, so a slower failover costs
    nothing here.
    """
    sc, layout, _ = scenario_of(seed, n_sensors, doa_fraction)
    names = [f'sensor_{k}' for k in range(layout.n)]
    exes = ['doa_sensor' if d else 'acoustic_sensor' for d in layout.is_doa.tolist()]
    nodes = ', '.join(['smart_target', 'sonar_sim', 'sonar_observer', '"report_source:radar"', 'fusion', 'vehicle_sim']
                      + [f'"{e}:{n}"' for e, n in zip(exes, names, strict=True)])
    text = _FIXED.format(nodes=nodes, duration=float(duration), rate=float(rate), seed=int(seed),
                         n_sensors=layout.n, doa_fraction=float(doa_fraction), width=sc.width, height=sc.height,
                         dt=float(dt), sync='true' if dt == 1.0 else 'false')
    for k, (name, d) in enumerate(zip(names, layout.is_doa.tolist(), strict=True)):
        x, y = (float(v) for v in layout.positions[k])
        text += _SENSOR.format(name=name, id=k, x=x, y=y, type='doa' if d else 'acoustic', seed=int(seed),
                               width=sc.width, height=float(grid_height), dt=float(dt),
                               comm_range=float(comm_range))
    return text


def seed_scenario(seed: int) -> dict:
    """The parsed maritime scenario of seed s: ``maritime_yaml(seed=s)`` (sensor layout and noise) with
    ``smart_target`` seed s + 2, ``sonar_sim`` and ``sonar_observer`` seed s + 3 (s = 1 is ``config/maritime.yaml``)."""
    cfg = yaml.safe_load(maritime_yaml(seed=seed))
    for node, offset in (('smart_target', 2), ('sonar_sim', 3), ('sonar_observer', 3)):
        cfg[f'/**/{node}']['ros__parameters']['seed'] = seed + offset
    return cfg


_FIXED = '''\
# Maritime scenario: an evading smart target crosses a seabed field of acoustic + DOA
# sensors; an observer AUV tracks it with SS-PF + covariance-control scheduling, the sensor network
# tracks the loudest source in its field with IDSQ, a coastal radar tracks a decoy that nobody
# pings; the fusion node scores every pair of tracks. See track_nodes/report/maritime.py.
# Run: python -m track_nodes.launch maritime --record      (bag, summary and bags/<bag>/picture.png)
# Generated by: python -c "from track_nodes.idsq.scenario_files import maritime_yaml as s; print(s(), end='')"
# Numbers: use 5.0, not 5, in float lists (ROS parameters do not mix integers and doubles).

track_launch:
  ros__parameters:
    nodes: [{nodes}]
    record_regex: "^/(sonar|idsq|radar|fusion)/"
    summary: maritime
    duration: {duration!r}
    rate: {rate!r}

/**/smart_target:
  ros__parameters:
    seed: 3
    period: {dt!r}                # = the network's dt: truth stamped k·dt is the network's step k - 1
    q_s: 0.05
    x0: [90.0, 0.0, 5.0, 6.0]  # enters the field at its south edge, cruising north at 6 m/s
    naive: false
    p_max: 0.9
    r_50: 600.0
    width: 100.0
    evade_speed: 9.0           # below the network tracker's v_max = 15 m/s (and the field is 250 m long)
    max_turn_rate_deg: 3.0
    max_accel: 1.0
    quiet_period: 10.0
    sync_observer: {sync}        # lock-step with the observer only when both step every 1 s
    track_id: smart_target

/**/sonar_sim:                    # the observer's route and sonar (a real sonar driver publishes the same)
  ros__parameters:
    seed: 4                    # the observer's seed: the readings it drew itself before the split
    period: 1.0
    sigma_b_deg: 1.0
    sigma_d: 5.0
    start: [60.0, -220.0]      # south of the field, following the target
    speed: 10.0
    heading0_deg: 0.0
    legs: [10.0, 0.0, 6.0, 10.0, 10.0, 0.0, 6.0, -10.0, 30.0, 0.0]
    observer_id: sonar_observer
    contact_frame: world
    lockstep: true

/**/sonar_observer:
  ros__parameters:
    seed: 4
    tracker: ss-pf
    delta: 50.0                # as config/sonar.yaml
    P_D: [5.0, 0.25, 5.0, 0.25]
    metric: spectral
    initial_pings: 2           # two active readings before eq. 7 decides: one 2.5-3σ range reading stays while trailing
    target_model: smart        # the SS-PF knows its pings make the target evade; model_* = smart_target's
    prediction: linear         # the mean through the manoeuvre, F P F' + Q: eq. 7 pings as with the CV model
    model_p_max: 0.9
    model_r_50: 600.0
    model_width: 100.0
    model_evade_speed: 9.0
    model_max_turn_rate_deg: 3.0
    model_max_accel: 1.0
    model_quiet_period: 10.0
    n_particles: 200
    regularize: true
    period: 1.0
    q_s: 1.0
    prior_mean: [100.0, 0.5, -5.0, 5.0]  # truth x0 + an offset (10 m, -10 m, 0.5 m/s, -1 m/s)
    prior_pos_std: 20.0
    prior_vel_std: 2.0
    body_frame: sonar_observer # sonar_sim's observer_id
    coast_after: 0.0           # lock-step: a predict-only step only when a later contact shows a gap
    track_id: sonar_track

/**/radar:                         # coastal radar: sees only the decoy
  ros__parameters:
    targets: [420.0, -3.0, -40.0, 5.5]   # decoy: its own course, north-west, never in the field
    truth_seed: 21
    q_s: 0.01
    period: {dt!r}                # = the network's dt: its sensors need the decoy's truth at every step
    report_targets: [0]
    sigma_major: 15.0
    sigma_minor: 8.0
    bearing_deg: 90.0
    noise_seed: 22
    prefix: /radar
    publish_truth: true        # the decoy's truth on /radar/truth (evaluation and the sensors' ears)

/**/fusion:
  ros__parameters:
    odometry_topics: [/sonar/estimate, /idsq/estimate]
    pose_topics: [/radar/t0]
    schedule: stamps           # score at the data's instants: a replay gives the same scores
    rate: 1.0
    method: exact
    threshold: 0.5
    combine: geometric
    window: 15                 # a true pair's scores dip for up to 5 instants between two pings: 5·2 ≤ 15·ln 2
    floor: 0.1353352832366127  # e^-2: a disjoint instant is evidence, not a veto (track_core.geofeasibility.track)
    prior_weight: 2.0          # a young pair's mean has 2 more instants at prior_score (AIS: the short-pair rule)
    prior_score: 0.8           # the true pair's typical instant score (geometric mean; docs/results/maritime.md)
    release_ratio: 0.8890097654027757  # e^(-2/17) = ε^(1/(window + prior_weight)): outlasts one disjoint instant
    stale_after: 2.5
    max_prediction: 3.0
    q_s: 1.0

/**/vehicle_sim:                   # the layout, and every sensor's readings of the target and the decoy
  ros__parameters:
    seed: {seed}
    n_sensors: {n_sensors}
    doa_fraction: {doa_fraction!r}
    width: {width!r}
    height: {height!r}
    dt: {dt!r}
    publish_truth: false
    truth_topics: [/sonar/target/truth, /radar/truth]   # each sensor hears the nearer source
'''

_SENSOR = '''
/**/{name}:
  ros__parameters:
    id: {id}
    position: [{x!r}, {y!r}]
    type: {type}
    seed: {seed}
    width: {width!r}
    height: {height!r}
    dt: {dt!r}
    cell: 5.0
    comm_range: {comm_range!r}
    selection: mi
    prediction: bank
    start: election
    ack_timeout: 10.0
    reading_durability: transient_local
'''

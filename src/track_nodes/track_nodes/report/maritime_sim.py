"""The maritime scenario's sources without ROS: what a recorded bag holds for ``network_replay``.

``simulate`` runs the three nodes whose output the network and the fusion see, from a scenario
file's parameters, with the same cores, seeds and lock-step as the nodes:

- ``smart_target`` (``SmartTarget``, ``default_rng(seed)``): step k (truth stamped t_k = k·T) moves
  x_{k-1} → x_k with the ping and position of the observer at t_{k-1} (``TargetGate`` with
  ``sync_observer``: step 1 has neither, so the observer is taken at the origin and unpinged);
- ``sonar_sim`` (noise on the first of ``SeedSequence(seed).spawn(2)``): step k reads x_k from
  ``ObserverTrajectory.state(k·T)`` in the mode the observer asked for after step k − 1, a contact in
  the world frame (``contacts.simulated_contact``: the REP-103 yaw the message carries);
- ``sonar_observer`` (``make_tracker`` on the second of ``SeedSequence(seed).spawn(2)``, with its
  ``target_model``, ``prediction`` and ``model_*`` parameters, ``target_model_of``): step k takes that
  contact (``contacts.paper_reading``, its own noise R), and its estimate is stamped t_k;
- the ``radar`` ``report_source`` (``CVTarget``, truth and noise seeds): the decoy's truth and its
  report with the 2σ ellipse at every t_k (dropouts drawn as the node does).

The result is ``maritime.load``'s dict (origin 0: the network's step origin; truth stamped k·T is its
step k − 1), so ``network_replay.replay`` / ``fuse`` / ``summary`` run on it unchanged. With the
launcher's seeds it gives the launcher's truths and tracks (``test_maritime`` compares them on a
recorded run), so a seed is measured in about a second instead of a lock-step ROS run.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import yaml

from track_core.demo import CVTarget
from track_core.geofeasibility.ellipse import ellipse_to_gaussian
from track_core.sonar import SmartTarget, SonarParams
from track_core.sonar.contacts import paper_reading, simulated_contact
from track_core.sonar.models import SensorMode
from track_core.sonar.scenario import ObserverTrajectory, Scenario
from track_core.sonar.sspf import make_tracker
from track_nodes.base.scenario_file import section_node
from track_nodes.fusion.report_source import ReportSourceParams
from track_nodes.report import maritime as mar
from track_nodes.sonar.observer_params import SonarObserverParams, p_d, smart_target_params, target_model_of
from track_nodes.sonar.smart_target import SmartTargetNodeParams
from track_nodes.sonar.sonar_sim import SonarSimParams


def _params(cls, entry: dict):
    return cls(**{f.name: entry[f.name] for f in dataclasses.fields(cls) if f.name in entry})


def sections(scenario: str | Path | dict) -> dict[str, dict]:
    """Node name → ros__parameters of a scenario file (path, text or parsed dict)."""
    if isinstance(scenario, Path):
        scenario = scenario.read_text()
    cfg = yaml.safe_load(scenario) if isinstance(scenario, str) else scenario
    return {section_node(k): (v or {}).get('ros__parameters', {}) for k, v in cfg.items()}


def _sonar_sim(sp: SonarSimParams) -> tuple[SonarParams, ObserverTrajectory, np.random.Generator]:
    """``sonar_sim``'s setup and ``_start_run``: its noise model, the observer's route, its noise Generator."""
    legs = np.asarray(sp.legs, dtype=float).reshape(-1, 2)
    traj = ObserverTrajectory(start=(float(sp.start[0]), float(sp.start[1])), speed=sp.speed,
                              heading0_deg=sp.heading0_deg, legs=tuple((float(a), float(b)) for a, b in legs))
    return (SonarParams(T=sp.period, sigma_b=math.radians(sp.sigma_b_deg), sigma_d=sp.sigma_d), traj,
            np.random.default_rng(np.random.SeedSequence(sp.seed).spawn(2)[0]))


def simulate(scenario: str | Path | dict, n_steps: int | None = None) -> dict:
    """``maritime.load``'s dict of one run of the scenario (``n_steps`` steps, default its duration / T)."""
    sec = sections(scenario)
    tp = _params(SmartTargetNodeParams, sec['smart_target'])
    op = _params(SonarObserverParams, sec['sonar_observer'])
    sp = _params(SonarSimParams, sec['sonar_sim'])
    rp = _params(ReportSourceParams, sec['radar'])
    T = float(tp.period)
    if n_steps is None:
        n_steps = round(float(sec.get('track_launch', {}).get('duration', 32.0)) / T)
    # smart_target (node setup)
    target = SmartTarget(np.asarray(tp.x0, dtype=float), sonar=SonarParams(T=T, q_s=tp.q_s),
                         params=smart_target_params(tp))
    t_rng = np.random.default_rng(tp.seed)
    sim_sonar, traj, o_rng = _sonar_sim(sp)
    # sonar_observer (node setup and _start_run)
    sonar = SonarParams(T=op.period, q_s=op.q_s, n_particles=op.n_particles)
    prior_cov = Scenario(params=sonar, prior_pos_std=op.prior_pos_std, prior_vel_std=op.prior_vel_std).prior_cov
    filter_ss = np.random.SeedSequence(op.seed).spawn(2)[1]
    tracker = make_tracker(op.tracker, sonar, np.random.default_rng(filter_ss), P_D=p_d(op.P_D), delta=op.delta,
                           metric=op.metric, regularize=op.regularize, initial_pings=op.initial_pings,
                           target_model=target_model_of(op), prediction=op.prediction)
    tracker.initialize(np.asarray(op.prior_mean, dtype=float), prior_cov)
    # radar (report_source setup)
    x0 = np.asarray(rp.targets, dtype=float).reshape(-1, 4)
    idx = list(range(len(x0))) if list(rp.report_targets) == [-1] else list(rp.report_targets)
    _, R = ellipse_to_gaussian(0.0, 0.0, 2 * rp.sigma_major, 2 * rp.sigma_minor, np.radians(rp.bearing_deg))
    ships = CVTarget(x0, T=rp.period, q_s=rp.q_s, R=R)
    r_truth, r_noise = np.random.default_rng(rp.truth_seed), np.random.default_rng(rp.noise_seed)

    t = T * np.arange(1, n_steps + 1)
    truth, est, cov, obs, pings = [], [], [], [], []
    decoy, rep_t, rep = [], [], []
    pinged, obs_prev = False, np.zeros(2)  # step 1: no observer step before it
    detections = 0
    for k in range(1, n_steps + 1):
        x = target.step(t_rng, pinged, obs_prev)
        detections = target.detections
        state = traj.state(k * sp.period)
        obs_xy = state[[0, 2]]
        mode = tracker.next_mode
        c = simulated_contact(o_rng, round(t[k - 1] * 1e9), x, obs_xy, mode, sim_sonar)
        e = tracker.step(paper_reading(c), mode, obs_xy, R=c.R)
        truth.append(x[[0, 2]])
        est.append(e.mean[[0, 2]])
        cov.append(e.cov[[0, 2]][:, [0, 2]])
        obs.append(obs_xy)
        pinged, obs_prev = mode is SensorMode.ACTIVE, obs_xy
        if pinged:
            pings.append(obs_xy)
        xs = ships.step(r_truth)
        zs = ships.report(r_noise)
        keep = r_noise.random(len(xs)) >= rp.dropout
        decoy.append(xs[0, [0, 2]])
        if keep[idx[0]]:
            rep_t.append(t[k - 1])
            rep.append(zs[idx[0]])
    rep_t = np.array(rep_t)
    return {'tracks': {mar.SONAR_TRACK: (t, np.array(est), np.array(cov)),
                       mar.RADAR_DECOY: (rep_t, np.array(rep).reshape(-1, 2), np.tile(R, (len(rep_t), 1, 1))),
                       mar.NETWORK_TRACK: (np.zeros(0), np.zeros((0, 2)), np.zeros((0, 2, 2)))},
            'truth': {mar.SONAR_TRACK: (t, np.array(truth)), mar.NETWORK_TRACK: (t, np.array(truth)),
                      mar.RADAR_DECOY: (t, np.array(decoy))},
            'observer': np.array(obs), 'pings': np.array(pings).reshape(-1, 2), 'detections': detections,
            'sensors': None, 'origin': 0.0, 'scores': {}}

"""Parameters of the ``fusion`` node (module docstring of ``track_nodes.fusion.fusion``).

The associator's settings are ``track_core.fusion.AssociatorConfig``, declared under the node's flat
parameter names (``threshold``, not ``associator.threshold``: the names users set) with the config's
defaults; ``associator_config`` maps the parameters back to the config, as a replay of a scenario
file does (``report.network_replay``).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from track_core.fusion import AssociatorConfig
from track_core.fusion.config import METHODS
from track_msgs_py.validate import InputPolicy
from track_nodes.base import ParameterError, param
from track_nodes.base.params import param_specs

_A = AssociatorConfig()
# Node parameter of each AssociatorConfig field whose name differs (stamp_rate: ``rate`` with ``schedule``
# stamps); the other fields the node declares keep their names; ``gate`` is not a parameter.
RENAMED = {'stamp_rate': 'rate', 'stamp_max_wait': 'stamps_max_wait'}
ASSOCIATOR_PARAMS = ('method', 'threshold', 'combine', 'window', 'floor', 'release_ratio', 'prior_weight',
                     'prior_score', 'n_samples', 'seed', 'same_source_pairs', 'stale_after', 'max_prediction', 'q_s',
                     'schedule', 'rate', 'stamps_max_wait')


@dataclass
class FusionParams:
    """Parameters of ``fusion``."""

    track_array_topics: list[str] = param([''], 'track_msgs/TrackArray topics, one source each (track id = '
        'topic/<track id>)')
    odometry_topics: list[str] = param([''], 'nav_msgs/Odometry track topics (track id = topic/child_frame_id)')
    pose_topics: list[str] = param([''], 'PoseWithCovarianceStamped track topics (one track per topic)')
    pose_track_topics: list[str] = param([''], 'PoseWithCovarianceStamped topics of many tracks of one source '
        '(header.frame_id = "<frame>#<local id>", track id = topic/<local id>)')
    navsatfix_topics: list[str] = param([''], 'sensor_msgs/NavSatFix position topics (a GNSS fix, e.g. the own '
        'ship), one track per topic, placed in map through the run\'s datum on map_datum (none yet: refused)')
    rate: float = param(2.0, 'scoring rate [Hz]', 0.01, 100.0, live=True)
    method: str = param(_A.method, 'geofeasibility score', choices=METHODS)
    n_samples: int = param(_A.n_samples, 'Monte-Carlo samples per pair (method mc)', 10, 1_000_000)
    threshold: float = param(_A.threshold, 'associate a pair when its combined score is at least this',
                             0.0, 1.0, live=True)
    release_ratio: float = param(_A.release_ratio, 'an associated pair stays associated while its combined score is '
        'at least release_ratio·threshold (hysteresis; 1: the paper\'s one level; ε^(1/window) keeps an association '
        'through one disjoint instant; track_core.fusion.associator)', 1e-6, 1.0, live=True)
    prior_weight: float = param(_A.prior_weight, 'prior of a young pair: its combination includes this many instants '
        'scoring prior_score, so one or two instant scores do not decide alone (0: the paper\'s combination; '
        'track_core.geofeasibility.track)', 0.0, 1e6, live=True)
    prior_score: float = param(_A.prior_score, 'the score of the prior\'s instants: the typical instant score of a '
                               'true pair', 1e-6, 1.0, live=True)
    combine: str = param(_A.combine, 'track-level combination of instant scores', choices=('geometric', 'harmonic'))
    window: int = param(_A.window, 'instant scores kept per pair for the combination', 1, 100_000)
    floor: float = param(_A.floor, 'floor ε of an instant score in the combination: a disjoint instant enters the '
        'mean as ε (0: the paper\'s means, one disjoint instant vetoes the window; e^-2 = 0.135: a 2σ ellipse misses '
        'its target that often; track_core.geofeasibility.track)', 0.0, 0.999)
    stale_after: float = param(_A.stale_after, 'a position report older than this drops out [s]', 1e-3, 1e6, live=True)
    max_prediction: float = param(_A.max_prediction, 'an Odometry track predicted further than this drops out [s]',
                                  1e-3, 1e6, live=True)
    q_s: float = param(_A.q_s, 'CV process-noise intensity used when predicting tracks [m²/s³]', 0.0, 1e6)
    seed: int = param(_A.seed, 'seed of the Generator used by the mc method', 0, 2**31 - 1)
    same_source_pairs: bool = param(_A.same_source_pairs, 'also score pairs from one source (Odometry: same topic; '
        'pose: same namespace)')
    schedule: str = param('timer', 'timer: score at node-clock ticks; stamps: at the data instants k/rate, '
        'deterministic (module docstring)', choices=('timer', 'stamps'))
    stamps_max_wait: float = param(_A.stamp_max_wait, 'schedule stamps: wait at most this long in data time for an '
        'input topic that has not delivered an instant before scoring it without (module docstring) [s]', 0.0, 1e6)
    publish_pairs: str = param('all', 'all: every pair of different sources; nonzero: only the pairs with a '
        'positive score or combined score, or associated (module docstring)', choices=('all', 'nonzero'))
    region: list[float] = param([-math.inf, math.inf, -math.inf, math.inf], 'shard: the rectangle [xmin, xmax, '
        'ymin, ymax] [m] whose pairs this node publishes (midpoint inside; default: the plane)')
    region_margin: float = param(0.0, 'shard: tracks within this of the rectangle are held, the others dropped [m] '
        '(track_core.fusion.region)', 0.0, 1e9)
    display_rate: float = param(1.0, 'rate of /fusion/markers [Hz] (at most one per scored instant)', 0.001, 100.0,
                                live=True)
    world_frame: str = param('map', 'the frame tracks are scored in; an input in another frame is moved into it '
        'through /tf and /tf_static at its stamp (module docstring)')
    tf_tolerance: float = param(0.2, 'an input stamped this much after the latest transform of its frame still uses '
        'that transform; later, it is refused as too old [s]', 0.0, 60.0, live=True)
    tf_history: float = param(10.0, 'seconds of /tf kept per transform (inputs older than that are refused) [s]',
                              0.1, 3600.0)
    warn_period: float = param(5.0, 'at most one bad-input warning per topic per this many seconds',
                               0.0, 1e6, live=True)
    stamp_horizon: float = param(InputPolicy.horizon, 'refuse reports stamped more than this ahead of the node clock '
                                 '[s]', 1e-3, 1e9, live=True)
    stamp_lead: float = param(2.0, 'look-ahead tolerance: refuse reports stamped more than this ahead of the node '
        'clock (a few report periods) [s]', 1e-3, 1e9, live=True)


def associator_config(values: Any) -> AssociatorConfig:
    """The ``AssociatorConfig`` of fusion node parameters ``values`` (a ``FusionParams`` or a mapping of
    parameter names, e.g. a scenario file's fusion section; a parameter left out has its node default),
    checked as the node checks them: a bad value → ``ParameterError``, one line naming the parameter."""
    given = dict(values) if isinstance(values, Mapping) else dataclasses.asdict(values)
    specs = {s.name: s for s in param_specs(FusionParams)}
    unknown = sorted(set(given) - set(specs))
    if unknown:
        raise ParameterError(f'parameters {", ".join(unknown)} are not fusion node parameters')
    p = {k: given.get(k, specs[k].default) for k in ASSOCIATOR_PARAMS}
    for k, v in p.items():
        specs[k].check(v)
    fields = {k: v for k, v in p.items() if k in AssociatorConfig.__dataclass_fields__}
    try:
        return AssociatorConfig(**fields, stamp_rate=p['rate'] if p['schedule'] == 'stamps' else None,
                                stamp_max_wait=p['stamps_max_wait'])
    except (ValueError, TypeError) as exc:
        name, _, rest = str(exc).partition(' ')
        raise ParameterError(f'parameter {RENAMED.get(name, name)} {rest}') from None

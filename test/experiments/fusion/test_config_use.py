"""The fusion benches build their associator from the node's config (one declaration of the defaults)."""

from __future__ import annotations

from track_core.fusion import AssociatorConfig
from track_nodes.fusion.params import associator_config


def test_the_benches_build_the_node_config():
    from track_experiments.fusion import core_bench, shards_bench

    node = associator_config(shards_bench.FUSION)
    assert node == AssociatorConfig(window=10, stale_after=2.5, stamp_rate=1.0)
    assert associator_config({'window': 10, 'stale_after': 2.5}) == core_bench.CONFIG

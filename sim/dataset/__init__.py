"""Labelled sonar datasets: SSS waterfall tiles and FLS frames with per-pixel instance masks
from the simulator's labels, in COCO format with pose/geometry sidecars (``undersea dataset``).

See :mod:`sim.dataset.export` for the output layout, :mod:`sim.dataset.config` for the
settings and the split into independently seeded shards.
"""

from sim.dataset.config import KINDS, DatasetConfig, ShardJob, plan_shards, shard_seeds
from sim.dataset.export import (
    DatasetResult,
    build_dataset,
    merge_shards,
    plan_dataset,
    resolve_scenario,
    run_shard,
)

__all__ = [
    "KINDS",
    "DatasetConfig",
    "DatasetResult",
    "ShardJob",
    "build_dataset",
    "merge_shards",
    "plan_dataset",
    "plan_shards",
    "resolve_scenario",
    "run_shard",
    "shard_seeds",
]

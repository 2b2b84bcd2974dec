"""Dataset settings, validated once at the boundary, and the split of N frames into shards.

A *frame* is one sonar acquisition turned into an image: a side-scan waterfall tile of
``tile_pings`` consecutive pings, or one forward-looking-sonar ping (every
``fls_interval_s`` seconds of simulated time). An FLS frame exported as both polar and
Cartesian fan gives two images of the same frame.

Shards: frames ``[k·shard_frames, (k+1)·shard_frames)`` form shard k, an independent
simulation of the scenario seeded by child k of ``numpy.random.SeedSequence(seed)``. The
split depends only on the settings, never on the number of workers, so 1, 2 or K workers
(local or Ray) produce the same files. Shard k starts recording after flying the first
``k / n_shards`` of the scenario (guidance + physics only, no sonar), so the shards cover
the whole mission instead of all imaging its first minute (``spread=False``: all start at
t = 0). ``min_objects`` keeps only frames showing that many objects.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

KINDS = ("sss", "fls", "both")
FLS_VIEWS = ("polar", "fan", "both")
SEGMENTATIONS = ("rle", "polygon")

#: Format version of the shard records and the COCO extras; bump when the layout changes.
FORMAT_VERSION = 1


def _bad(name: str, value: Any, allowed: str) -> ValueError:
    return ValueError(f"{name} = {value!r} is not allowed; allowed: {allowed}")


def _is_int(v: Any) -> bool:
    return isinstance(v, int | np.integer) and not isinstance(v, bool)


@dataclass(frozen=True)
class DatasetConfig:
    """What ``undersea dataset`` exports.

    scenario       : built-in scenario name (``undersea scenarios``) or a .toml path.
    frames         : number of frames N >= 1 (SSS tiles and FLS pings together).
    seed           : dataset seed >= 0; shard k uses child k of SeedSequence(seed).
    kind           : "sss" (side-scan tiles), "fls" (forward-looking frames) or "both".
    tile_pings     : pings per side-scan tile P (rows of the tile image), 2..100000.
    fls_view       : FLS images as "polar" (bins x beams), "fan" (Cartesian) or "both".
    fls_interval_s : simulated seconds between two exported FLS frames (> 0; the sonar
                     pings at its own rate, every round(interval x rate)-th ping is kept).
    shard_frames   : frames per shard (the unit of parallel work and of resume), >= 1.
                     Each shard builds its world and, with ``spread``, first flies to its
                     offset (physics only, about a quarter of the CPU time of imaging the same
                     stretch with a 64-ping side-scan): larger shards amortise both.
    segmentation   : COCO instance masks as "rle" (pixel-exact) or "polygon" (pixel-edge
                     contours, exact for hole-free masks).
    min_objects    : keep only frames showing at least this many objects (0: keep all).
    spread         : start shard k after k/n_shards of the mission (True) or all at t = 0.
    save_linear    : also write float32 .npy linear intensity (µPa² after TVG) per image.
    overrides      : dotted scenario overrides, e.g. (("vehicles[0].sonars[0].overrides.samples_per_side", 200),).
    licence        : licence named in the dataset card and the COCO ``licenses``.
    """

    scenario: str
    frames: int
    seed: int = 0
    kind: str = "both"
    tile_pings: int = 64
    fls_view: str = "polar"
    fls_interval_s: float = 1.0
    shard_frames: int = 32
    segmentation: str = "rle"
    save_linear: bool = False
    min_objects: int = 0
    spread: bool = True
    overrides: tuple[tuple[str, Any], ...] = field(default_factory=tuple)
    licence: str = "CC-BY-4.0"

    def __post_init__(self) -> None:
        if not isinstance(self.scenario, str) or not self.scenario:
            raise _bad("scenario", self.scenario, "a built-in scenario name or a .toml path")
        if not _is_int(self.frames) or self.frames < 1:
            raise _bad("frames", self.frames, "an integer >= 1")
        if not _is_int(self.seed) or self.seed < 0:
            raise _bad("seed", self.seed, "an integer >= 0")
        if self.kind not in KINDS:
            raise _bad("kind", self.kind, ", ".join(KINDS))
        if not _is_int(self.tile_pings) or not 2 <= self.tile_pings <= 100_000:
            raise _bad("tile_pings", self.tile_pings, "an integer in 2 .. 100000")
        if self.fls_view not in FLS_VIEWS:
            raise _bad("fls_view", self.fls_view, ", ".join(FLS_VIEWS))
        x = self.fls_interval_s
        if (
            isinstance(x, bool)
            or not isinstance(x, int | float)
            or not (math.isfinite(x) and x > 0)
        ):
            raise _bad("fls_interval_s", x, "a finite number of seconds > 0")
        if not _is_int(self.shard_frames) or self.shard_frames < 1:
            raise _bad("shard_frames", self.shard_frames, "an integer >= 1")
        if self.segmentation not in SEGMENTATIONS:
            raise _bad("segmentation", self.segmentation, ", ".join(SEGMENTATIONS))
        if not _is_int(self.min_objects) or self.min_objects < 0:
            raise _bad("min_objects", self.min_objects, "an integer >= 0")
        if not isinstance(self.spread, bool):
            raise _bad("spread", self.spread, "True or False")
        if not isinstance(self.overrides, tuple) or any(
            not (isinstance(kv, tuple) and len(kv) == 2 and isinstance(kv[0], str))
            for kv in self.overrides
        ):
            raise _bad("overrides", self.overrides, "a tuple of (dotted key, value) pairs")

    @property
    def sonar_kinds(self) -> tuple[str, ...]:
        return ("sss", "fls") if self.kind == "both" else (self.kind,)

    @property
    def fls_views(self) -> tuple[str, ...]:
        return ("polar", "fan") if self.fls_view == "both" else (self.fls_view,)

    @property
    def n_shards(self) -> int:
        return math.ceil(self.frames / self.shard_frames)

    def settings(self) -> dict:
        """JSON-able settings (everything that determines the dataset's bytes)."""
        d = asdict(self)
        d["overrides"] = [[k, v] for k, v in self.overrides]
        d["format_version"] = FORMAT_VERSION
        return d


@dataclass(frozen=True)
class ShardJob:
    """One shard: frames [first_frame, first_frame + n_frames) of the dataset.

    seed      : the scenario seed of this shard's simulation (from SeedSequence.spawn).
    offset_s  : simulated seconds flown before the first frame is recorded.
    scenario  : the decoded scenario table with the overrides applied (parsed in the worker).
    """

    index: int
    first_frame: int
    n_frames: int
    seed: int
    offset_s: float
    scenario: dict
    config: DatasetConfig
    settings_hash: str


def settings_hash(cfg: DatasetConfig, scenario_data: dict) -> str:
    """SHA-256 (24 hex) of the whole plan: the settings, the resolved scenario table and
    the code version (sim.version), so a resume never mixes shards of different plans."""
    from sim.version import code_version

    blob = json.dumps(
        {"settings": cfg.settings(), "scenario": scenario_data, "code": code_version()},
        sort_keys=True,
        default=str,
    )
    return hashlib.sha256(blob.encode()).hexdigest()[:24]


def shard_seeds(seed: int, n: int) -> list[int]:
    """Scenario seeds of shards 0..n-1: child k of SeedSequence(seed), as a uint32.

    Child k's spawn key is (k,), so shard k's seed does not depend on n."""
    return [int(c.generate_state(1, np.uint32)[0]) for c in np.random.SeedSequence(seed).spawn(n)]


def plan_shards(
    cfg: DatasetConfig, scenario_data: dict, duration_s: float, frame_period_s: float
) -> list[ShardJob]:
    """The shards of a dataset.

    duration_s     : the scenario's simulated duration, s (shard offsets spread over it).
    frame_period_s : expected simulated seconds per frame (for the offsets only; with
                     ``min_objects`` frames come slower, and shards may overlap in time).
    """
    n = cfg.n_shards
    seeds = shard_seeds(cfg.seed, n)
    h = settings_hash(cfg, scenario_data)
    jobs = []
    for k in range(n):
        first = k * cfg.shard_frames
        count = min(cfg.shard_frames, cfg.frames - first)
        span = max(0.0, duration_s - count * frame_period_s) if cfg.spread else 0.0
        offset = round(k / n * span, 3)
        jobs.append(ShardJob(k, first, count, seeds[k], offset, scenario_data, cfg, h))
    return jobs

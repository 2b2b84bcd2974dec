"""What a sweep runs: the cross product of varied parameters times seeds."""

from __future__ import annotations

import itertools
import json
import re
from dataclasses import dataclass, field

_KEY = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z0-9_]+)*$")


def _coerce(text: str):
    """'3' -> 3, '0.5' -> 0.5, 'true' -> True, anything else stays a string."""
    low = text.strip().lower()
    if low in ("true", "false"):
        return low == "true"
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text.strip()


def parse_vary(items: list[str] | None) -> dict[str, list]:
    """Parse ``--vary key=v1,v2,...`` options into ``{key: [v1, v2, ...]}``.

    Raises ValueError naming the bad item and the expected form.
    """
    out: dict[str, list] = {}
    for item in items or []:
        if "=" not in item:
            raise ValueError(f"--vary {item!r}: expected key=v1,v2,... (e.g. slam.estimator=aekf,fastslam2)")
        key, _, values = item.partition("=")
        key = key.strip()
        if not _KEY.match(key):
            raise ValueError(f"--vary {item!r}: key {key!r} must be a dotted name like slam.estimator")
        vals = [_coerce(v) for v in values.split(",") if v.strip()]
        if not vals:
            raise ValueError(f"--vary {item!r}: no values after '='")
        if key in out:
            raise ValueError(f"--vary {item!r}: key {key!r} given twice")
        out[key] = vals
    return out


@dataclass(frozen=True)
class RunSpec:
    """One run: a variant (parameter overrides) and a seed. ``run_id`` names its files."""

    variant: tuple[tuple[str, object], ...]
    seed: int

    @property
    def variant_id(self) -> str:
        if not self.variant:
            return "base"
        return ",".join(f"{k}={v}" for k, v in self.variant)

    @property
    def run_id(self) -> str:
        safe = re.sub(r"[^A-Za-z0-9_.=,+-]", "_", self.variant_id)
        return f"{safe}__seed{self.seed}"

    def params(self) -> dict:
        return dict(self.variant)

    def to_json(self) -> str:
        return json.dumps({"variant": [list(kv) for kv in self.variant], "seed": self.seed})


@dataclass(frozen=True)
class SweepPlan:
    """``runs`` seeds (base_seed, base_seed + 1, ...) for every combination of ``vary``."""

    target: str
    runs: int
    vary: dict[str, list] = field(default_factory=dict)
    base_seed: int = 1

    def __post_init__(self) -> None:
        if not isinstance(self.runs, int) or self.runs < 1:
            raise ValueError(f"runs must be an integer >= 1, got {self.runs!r}")
        if not self.target:
            raise ValueError("target must name a scenario or slam:<experiment>")

    def specs(self) -> list[RunSpec]:
        keys = list(self.vary)
        combos = itertools.product(*(self.vary[k] for k in keys)) if keys else [()]
        return [
            RunSpec(variant=tuple(zip(keys, combo)), seed=self.base_seed + i)
            for combo in combos
            for i in range(self.runs)
        ]

"""A straight side-scan survey line over a flat seabed, with the ray-cast sonar and its
realism chain (:mod:`sim.sonar.chain`), for calibration.

The vehicle flies along +x at ``altitude_m`` and ``speed_mps``, pinging at the preset's
rate; the sonar is ``preset(spec.preset, max_range=…, samples_per_side=…, <overrides>)``
with linear output (``log_compression=False``: intensity µPa² after TVG, gain and ADC).
The rng is re-seeded with ``spec.seed`` at every call, so two calls with the same
overrides give the same bytes (common random numbers for the fit).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np

from sim.sonar.config import preset
from sim.sonar.scenes import SonarScene, build_scene
from sim.sonar.sidescan import SideScanSonar


@dataclass(frozen=True)
class SurveySpec:
    """altitude_m: over the seabed, m; max_range_m: slant range of a side, m;
    samples_per_side; pings per simulated waterfall; speed_mps along track; preset name;
    seed of the speckle/noise draws."""

    altitude_m: float
    max_range_m: float
    samples_per_side: int
    pings: int = 48
    speed_mps: float = 1.5
    preset: str = "deepeye680d_realistic"
    seed: int = 0

    def __post_init__(self) -> None:
        if not 0.5 <= self.altitude_m < self.max_range_m:
            raise ValueError(
                f"altitude_m = {self.altitude_m}; allowed 0.5 <= altitude < max_range_m "
                f"({self.max_range_m})"
            )
        if not 16 <= self.samples_per_side <= 8192:
            raise ValueError(f"samples_per_side = {self.samples_per_side}; allowed 16 .. 8192")
        if not 32 <= self.pings <= 2000:
            raise ValueError(f"pings = {self.pings}; allowed 32 .. 2000")
        if not self.speed_mps > 0:
            raise ValueError(f"speed_mps = {self.speed_mps}; must be > 0")


class RaycastSurvey:
    """Callable ``survey(overrides) -> (pings, 2S) float64`` linear intensity waterfall."""

    def __init__(self, spec: SurveySpec):
        self.spec = spec
        preset(spec.preset)  # fails early on an unknown preset name

    @cached_property
    def scene(self) -> SonarScene:
        size = 2.0 * (self.spec.max_range_m + self.spec.pings * self.spec.speed_mps) + 20.0
        return build_scene(altitude=self.spec.altitude_m, seabed_size=size, seabed_cells=40)

    def config(self, overrides: dict[str, Any]):
        """The sonar config with the spec's geometry and the given realism overrides."""
        return preset(
            self.spec.preset,
            max_range=self.spec.max_range_m,
            samples_per_side=self.spec.samples_per_side,
            log_compression=False,
            **overrides,
        )

    def full_scale(self, overrides: dict[str, Any]) -> float | None:
        """Clip level of the output intensity (µPa²), None when the ADC is off."""
        rz = self.config(overrides).acoustic.realism
        if rz is None or rz.bit_depth <= 0:
            return None
        return 10.0 ** (rz.full_scale_db / 10.0)

    def __call__(self, overrides: dict[str, Any]) -> np.ndarray:
        sc, spec = self.scene, self.spec
        cfg = self.config(overrides)
        sonar = SideScanSonar(
            cfg,
            sc.model,
            sc.data,
            (sc.sites["sss_port"], sc.sites["sss_starboard"]),
            sc.geom_object_id,
            sc.geom_reflectivity,
            sc.water,
        )
        rng = np.random.default_rng(spec.seed)
        step = spec.speed_mps / cfg.ping_rate_hz
        x0 = -0.5 * spec.pings * step
        rows = []
        for i in range(spec.pings):
            sc.move_vehicle(x0 + i * step, 0.0, spec.altitude_m)
            rows.append(sonar.ping(sc.data, rng).intensity)
        return np.asarray(rows, dtype=np.float64)

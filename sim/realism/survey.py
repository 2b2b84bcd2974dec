"""A straight side-scan survey line over a flat seabed, with the ray-cast sonar and its
realism chain (:mod:`sim.sonar.chain`), for calibration.

The vehicle flies along +x at ``altitude_m`` and ``speed_mps``, pinging at the preset's
rate, in ``segments`` equal legs ``segment_spacing_m`` apart along x (one leg by default):
a few short legs spread over the sediment patches give both sides the same mix of
sediments for the cost of one long leg of the same pings (a 3-m leg sees different patches
on port and starboard, so its saturation differs by side). Keep ``pings / segments`` a
multiple of the 16-ping statistics tile so no tile spans two legs; the sonar is ``preset(spec.preset, max_range=…, samples_per_side=…, <overrides>)``
with linear output (``log_compression=False``: intensity µPa² after TVG, gain and ADC).
The rng is re-seeded with ``spec.seed`` at every call, so two calls with the same
overrides give the same bytes (common random numbers for the fit).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np

from sim.sonar.config import PRESETS, preset
from sim.sonar.preset_file import is_preset_file, load_preset_file
from sim.sonar.receiver import digitise
from sim.sonar.scenes import SonarScene, build_scene
from sim.sonar.sidescan import SideScanSonar


@dataclass(frozen=True)
class SurveySpec:
    """altitude_m: over the seabed, m; max_range_m: slant range of a side, m;
    samples_per_side; pings per simulated waterfall; speed_mps along track; preset name
    (built-in, or a preset file: sim.sonar.preset_file);
    seed of the speckle/noise draws; segments: legs the pings are split into (equal,
    consecutive in the waterfall), their starts segment_spacing_m apart along x;
    display_bits: 0 = linear intensity after TVG, gain and ADC (µPa²); n > 0 = what a
    recreational unit stores: the log-compressed display (display_floor_db,
    dynamic_range_db) quantised to n-bit levels L, returned as L² (the readers take stored
    samples as amplitudes); leg_altitudes_m: one altitude per leg (m) to fly a recording's
    altitude track (e.g. the median of each of its consecutive chunks), empty = altitude_m
    for every leg."""

    altitude_m: float
    max_range_m: float
    samples_per_side: int
    pings: int = 48
    speed_mps: float = 1.5
    preset: str = "deepeye680d_realistic"
    seed: int = 0
    segments: int = 1
    segment_spacing_m: float = 30.0
    display_bits: int = 0
    leg_altitudes_m: tuple[float, ...] = ()

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
        if not (1 <= self.segments <= self.pings and self.pings % self.segments == 0):
            raise ValueError(
                f"segments = {self.segments}; must divide pings ({self.pings}) into equal legs"
            )
        if not (isinstance(self.display_bits, int) and 0 <= self.display_bits <= 16):
            raise ValueError(f"display_bits = {self.display_bits!r}; allowed 0 .. 16")
        if not 0 < self.segment_spacing_m <= 1000:
            raise ValueError(f"segment_spacing_m = {self.segment_spacing_m}; allowed (0, 1000] m")
        if self.leg_altitudes_m and len(self.leg_altitudes_m) != self.segments:
            raise ValueError(
                f"leg_altitudes_m has {len(self.leg_altitudes_m)} values; need one per leg "
                f"(segments = {self.segments})"
            )
        for a in self.leg_altitudes_m:
            if not 0.5 <= a < self.max_range_m:
                raise ValueError(
                    f"leg_altitudes_m holds {a}; allowed 0.5 <= altitude < max_range_m "
                    f"({self.max_range_m})"
                )

    def leg_altitude(self, leg: int) -> float:
        """Altitude of leg ``leg`` (m)."""
        return float(self.leg_altitudes_m[leg]) if self.leg_altitudes_m else self.altitude_m

    @property
    def extent_m(self) -> float:
        """Along-track length covered by the legs (m): for the seabed's size."""
        leg = self.pings / self.segments * self.speed_mps
        return (self.segments - 1) * self.segment_spacing_m + leg


class RaycastSurvey:
    """Callable ``survey(overrides) -> (pings, 2S) float64`` linear intensity waterfall."""

    def __init__(self, spec: SurveySpec):
        self.spec = spec
        self.base, self.base_overrides = spec.preset, {}
        if spec.preset not in PRESETS and is_preset_file(spec.preset):
            pf = load_preset_file(spec.preset)  # a calibrated preset: start from its values
            self.base, self.base_overrides = pf.base, dict(pf.overrides)
        preset(self.base)  # fails early on an unknown preset name

    def start_value(self, name: str) -> float:
        """The preset's own value of a realism or acoustic field (``range_cell_m`` None →
        the sonar's range resolution c/2B; ``display_floor_db`` None → its default
        SL + 10·log10 μ − 60 dB; ``low_grazing_knee_deg`` None → 15°; ``micro_slope_deg``
        None → 1°; ``tvg_exponent`` None → 4, the r⁴ law), to start a fit from."""
        cfg = self.config({})
        ac = cfg.acoustic
        v = getattr(ac.realism, name) if hasattr(ac.realism, name) else getattr(ac, name)
        if v is None and name == "range_cell_m":
            v = cfg.range_resolution
        if v is None and name == "display_floor_db":
            v = ac.source_level_db + ac.lambert_mu_db - 60.0
        if v is None and name == "low_grazing_knee_deg":
            v = 15.0  # off in the preset: start the fit from a knee near sand's data
        if v is None and name == "micro_slope_deg":
            v = 1.0
        if v is None and name == "tvg_exponent":
            v = 4.0  # None = the r⁴ law
        if v is None:
            raise ValueError(f"preset {self.spec.preset!r}: {name} is off; cannot fit it")
        return float(v)

    @cached_property
    def scene(self) -> SonarScene:
        size = 2.0 * (self.spec.max_range_m + self.spec.extent_m) + 20.0
        return build_scene(altitude=self.spec.altitude_m, seabed_size=size, seabed_cells=40)

    def config(self, overrides: dict[str, Any]):
        """The sonar config with the spec's geometry and the given realism overrides."""
        return preset(
            self.base,
            **{
                **self.base_overrides,
                "max_range": self.spec.max_range_m,
                "samples_per_side": self.spec.samples_per_side,
                "log_compression": self.spec.display_bits > 0,
                **overrides,
            },
        )

    def full_scale(self, overrides: dict[str, Any]) -> float | None:
        """Clip level of the output intensity (µPa²; display: the top level²), None when
        the ADC is off."""
        if self.spec.display_bits:
            return float((2**self.spec.display_bits - 1) ** 2)
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
        per_leg = spec.pings // spec.segments
        x0 = -0.5 * ((spec.segments - 1) * spec.segment_spacing_m + per_leg * step)
        rows = []
        for i in range(spec.pings):
            leg, k = divmod(i, per_leg)
            x = x0 + leg * spec.segment_spacing_m + k * step
            sc.move_vehicle(x, 0.0, spec.leg_altitude(leg))
            rows.append(sonar.ping(sc.data, rng).intensity)
        out = np.asarray(rows, dtype=np.float64)
        if spec.display_bits:
            out = np.round(out * (2**spec.display_bits - 1)) ** 2
        return out


class GainProfiledSurvey:
    """The survey with the receiver gain solved, not searched: each call simulates with
    the gain at 0 dB and the ADC off, then sets ``receiver_gain_db`` so that the clipped
    fraction of each side is the target's (the gain that clips a fraction t of a side is
    full scale / its (1 − t) quantile; the two sides' gains averaged in dB) and applies
    :func:`sim.sonar.receiver.digitise` with the preset's ADC, which is what the sonar
    does after TVG. The fit then has one parameter less, and the one whose objective is
    flat where nothing clips. ``gains[key]`` remembers the gain of each call."""

    def __init__(self, survey: RaycastSurvey, saturation: tuple[float, float]):
        if not all(0.0 < t < 0.5 for t in saturation):
            raise ValueError(
                f"target saturation {saturation}: the gain is solved only for a recording "
                "that clips (0 < fraction < 0.5 per side); use --gain fit"
            )
        rz = survey.config({}).acoustic.realism
        if rz is None or rz.bit_depth <= 0:
            raise ValueError(f"preset {survey.spec.preset!r} has no ADC (bit_depth 0)")
        self.survey, self.saturation = survey, tuple(saturation)
        self.base, self.base_overrides, self.spec = survey.base, survey.base_overrides, survey.spec
        self.gains: dict[tuple, float] = {}

    def full_scale(self, overrides: dict[str, Any]) -> float | None:
        return self.survey.full_scale(overrides)

    def __call__(self, overrides: dict[str, Any]) -> np.ndarray:
        ov = {k: v for k, v in overrides.items() if k != "receiver_gain_db"}
        raw = self.survey({**ov, "receiver_gain_db": 0.0, "bit_depth": 0})
        rz = self.survey.config(ov).acoustic.realism
        s = raw.shape[1] // 2
        tops = [
            np.quantile(side, 1.0 - t) for side, t in zip((raw[:, :s], raw[:, s:]), self.saturation)
        ]
        fs_db = rz.full_scale_db
        gain = float(np.mean([fs_db - 10.0 * np.log10(max(q, 1e-300)) for q in tops]))
        self.gains[tuple(sorted(ov.items()))] = gain
        return digitise(raw, gain, rz.bit_depth, fs_db)

    def gain_for(self, overrides: dict[str, Any]) -> float:
        """The solved gain (dB) of an earlier call with these overrides."""
        ov = {k: v for k, v in overrides.items() if k != "receiver_gain_db"}
        key = tuple(sorted(ov.items()))
        if key not in self.gains:
            self(ov)
        return self.gains[key]

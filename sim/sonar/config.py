"""Sonar configuration: water properties, acoustic model settings, and sonar presets.

Config objects are frozen dataclasses validated on construction: bad values raise
``ValueError`` naming the field, the bad value and the allowed range. Angles are given
in degrees at this boundary (``*_deg`` fields) and converted to radians inside the
simulators. Frequencies in Hz, ranges in m, levels in dB re 1 µPa (at 1 m for the source).

Presets (``preset(name, **overrides)``), from ``../shared/REFERENCE.md`` where it gives a
number; the rest are typical values for that class of instrument (marked "assumed"):

* ``deepeye340d``: 340 kHz chirp SSS, 1.5 cm resolution, 15–200 m range settings.
* ``deepeye680d``: 680 kHz chirp SSS, 1 cm resolution, 10–200 m, ~1000 samples per side.
* ``klein3500``: Klein 3500-like 400 kHz SSS (its high-frequency channel), low-res image.
* ``blueview_p900_90``: 2-D FLS, 900 kHz, 90° horizontal FOV, 20° vertical, 100 m,
  2.51 cm resolution, 15 Hz.
* ``msis``: mechanically scanned imaging sonar (Tritech Micron/Miniking-like, assumed).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, Literal, Protocol

import numpy as np

from sim.sonar.effects import RealismConfig

SpeckleModel = Literal["none", "rayleigh", "k"]
BeamPattern = Literal["gaussian", "sinc", "rect"]
TvgMode = Literal["none", "spreading", "spreading_absorption"]
AbsorptionModel = Literal["francois_garrison", "ainslie_mccolm"]


def _check_range(name: str, value: float, lo: float, hi: float, *, lo_open: bool = False) -> None:
    ok = (lo < value if lo_open else lo <= value) and value <= hi and math.isfinite(value)
    if not ok:
        bracket = "(" if lo_open else "["
        raise ValueError(f"{name} = {value!r} is outside the allowed range {bracket}{lo}, {hi}]")


def _check_choice(name: str, value: Any, allowed: tuple) -> None:
    if value not in allowed:
        raise ValueError(
            f"{name} = {value!r} is not allowed; allowed: {', '.join(map(repr, allowed))}"
        )


class WaterLike(Protocol):
    """What a sonar needs to know about the water (``sim.world``'s Water fits by duck typing).

    temperature_c (°C), salinity_psu (PSU ≈ ‰), sound_speed (m/s), depth (m: depth of the
    world z = 0 datum below the sea surface; a point at world z lies at depth ``depth - z``).
    An optional ``ph`` attribute (default 8.0) feeds the boric-acid absorption term.
    """

    temperature_c: float
    salinity_psu: float
    sound_speed: float
    depth: float


@dataclass(frozen=True)
class Water:
    """Sea water properties (defaults: Trondheim Fjord field trial of the reference thesis,
    except salinity 35.0 PSU instead of 35.07 so that Francois–Garrison's 30–35 PSU validity
    range below 500 kHz holds).

    temperature_c: °C; salinity_psu: PSU; sound_speed: m/s; depth: m, depth of the world
    z = 0 datum below the sea surface; ph: pH of sea water.
    """

    temperature_c: float = 7.69
    salinity_psu: float = 35.0
    sound_speed: float = 1483.25
    depth: float = 92.0
    ph: float = 8.0

    def __post_init__(self) -> None:
        _check_range("water.temperature_c", self.temperature_c, -3.0, 40.0)
        _check_range("water.salinity_psu", self.salinity_psu, 0.0, 50.0)
        _check_range("water.sound_speed", self.sound_speed, 1300.0, 1700.0)
        _check_range("water.depth", self.depth, 0.0, 11000.0)
        _check_range("water.ph", self.ph, 6.0, 9.0)


@dataclass(frozen=True)
class AcousticConfig:
    """Echo-formation settings shared by all sonars.

    source_level_db: dB re 1 µPa at 1 m. noise_level_db: receiver noise per sample, dB re
    1 µPa (intensity added before speckle). lambert_mu_db: Lambert backscatter parameter
    10·log10(μ) of a material with reflectivity 1 (sand ≈ −27 dB); a hit on geom g scatters
    with μ·geom_reflectivity[g]·cos²(incidence). speckle: "rayleigh" (intensity exponential,
    amplitude Rayleigh), "k" (K-distributed: gamma texture of shape ``k_shape`` times
    exponential), or "none" (mean intensity). tvg: time-varying gain applied after
    speckle and noise ("spreading": ×r⁴ two-way spherical; "spreading_absorption": also
    ×10^(2αr/10)). log_compression: output 10·log10 intensity mapped linearly from
    [display_floor_db, display_floor_db + dynamic_range_db] to [0, 1]; off → linear
    intensity (µPa²). absorption_model: seawater absorption formula. specular_db: peak of a
    near-normal-incidence (facet/Kirchhoff-like) lobe added to Lambert,
    σ_s = 10^(specular_db/10)·refl·exp(−θ²/(2w²)) with w = specular_width_deg (None: off);
    it makes the first bottom return (nadir line) bright as in real SSS. realism: the
    image-realism effects (:class:`sim.sonar.effects.RealismConfig`; None: all off).
    """

    source_level_db: float = 210.0
    noise_level_db: float = 40.0
    lambert_mu_db: float = -27.0
    speckle: SpeckleModel = "rayleigh"
    k_shape: float = 3.0
    tvg: TvgMode = "spreading_absorption"
    log_compression: bool = True
    display_floor_db: float | None = None
    dynamic_range_db: float = 50.0
    absorption_model: AbsorptionModel = "francois_garrison"
    specular_db: float | None = -8.0
    specular_width_deg: float = 10.0
    realism: RealismConfig | None = None

    def __post_init__(self) -> None:
        _check_range("source_level_db", self.source_level_db, 100.0, 260.0)
        _check_range("noise_level_db", self.noise_level_db, -100.0, 200.0)
        _check_range("lambert_mu_db", self.lambert_mu_db, -80.0, 0.0)
        _check_choice("speckle", self.speckle, ("none", "rayleigh", "k"))
        _check_range("k_shape", self.k_shape, 0.0, 1e6, lo_open=True)
        _check_choice("tvg", self.tvg, ("none", "spreading", "spreading_absorption"))
        _check_range("dynamic_range_db", self.dynamic_range_db, 1.0, 200.0)
        _check_choice(
            "absorption_model", self.absorption_model, ("francois_garrison", "ainslie_mccolm")
        )
        if self.specular_db is not None:
            _check_range("specular_db", self.specular_db, -100.0, 20.0)
        _check_range("specular_width_deg", self.specular_width_deg, 0.0, 45.0, lo_open=True)
        if self.realism is not None and not isinstance(self.realism, RealismConfig):
            raise ValueError(f"realism = {self.realism!r}; allowed: None or a RealismConfig")
        if self.display_floor_db is not None:
            _check_range("display_floor_db", self.display_floor_db, -100.0, 300.0)


def _check_common(cfg: Any, max_range_allowed: float) -> None:
    _check_range("frequency_hz", cfg.frequency_hz, 100.0, 1.0e6)
    _check_range("max_range", cfg.max_range, 0.0, max_range_allowed, lo_open=True)
    _check_range("range_resolution", cfg.range_resolution, 0.0, 10.0, lo_open=True)
    _check_range("min_range", cfg.min_range, 0.0, cfg.max_range)
    if cfg.min_range >= cfg.max_range:
        raise ValueError(
            f"min_range = {cfg.min_range!r} must be below max_range = {cfg.max_range!r}"
        )
    _check_range("ping_rate_hz", cfg.ping_rate_hz, 0.0, 1000.0, lo_open=True)
    _check_range("mount_tolerance", cfg.mount_tolerance, 0.0, 5.0)


def _check_samples(name: str, n: int, span: float, resolution: float) -> None:
    max_n = math.floor(span / resolution + 1e-9)
    if not isinstance(n, int) or n < 2 or n > max_n:
        raise ValueError(
            f"{name} = {n!r} is not supported: allowed 2 .. {max_n} "
            f"(range span {span} m / range_resolution {resolution} m)"
        )


def _check_polar(cfg: Any) -> None:
    """Checks shared by the range-binned polar sonars (FLS, MSIS)."""
    _check_common(cfg, 1000.0)
    _check_samples("n_bins", cfg.n_bins, cfg.max_range - cfg.min_range, cfg.range_resolution)
    _check_range("tilt_deg", cfg.tilt_deg, -90.0, 90.0)
    _check_choice("beam_pattern", cfg.beam_pattern, ("gaussian", "sinc", "rect"))
    _check_range("sidelobe_db", cfg.sidelobe_db, -200.0, 0.0)


class _RangeBins:
    """``bin_width`` of a sonar binned over [min_range, max_range] in n_bins, m."""

    @property
    def bin_width(self) -> float:
        return (self.max_range - self.min_range) / self.n_bins

    @property
    def bin_centres(self) -> np.ndarray:
        """(n_bins,) range at the centre of each bin, m."""
        return self.min_range + (np.arange(self.n_bins) + 0.5) * self.bin_width


@dataclass(frozen=True)
class SSSConfig:
    """Side-scan sonar (port + starboard transducers).

    frequency_hz; max_range (m, slant); min_range (m, first sample's near edge, usually 0);
    samples_per_side: range bins per side, bin width (max_range − min_range)/samples;
    range_resolution (m): the pulse's resolution c/(2B), which bounds samples_per_side;
    along_track_beamwidth_deg / vertical_beamwidth_deg: −3 dB two-way widths;
    depression_deg: beam axis below horizontal; sidelobe_db: floor of the one-way beam
    pattern (nadir still returns, as in real SSS); ping_rate_hz;
    rays_along_track: rays across the along-track beam; ray_oversampling: rays per range
    bin on a flat seabed; angular_grid_deg: spacing of the uniform depression-angle grid
    joined to that (covers nadir and above the seabed horizon); mount_tolerance (m): how far outside the vehicle's geoms the
    site may be; acoustic: echo formation.
    """

    frequency_hz: float = 680e3
    max_range: float = 50.0
    min_range: float = 0.0
    samples_per_side: int = 1000
    range_resolution: float = 0.01
    along_track_beamwidth_deg: float = 0.3
    vertical_beamwidth_deg: float = 50.0
    depression_deg: float = 20.0
    beam_pattern: BeamPattern = "gaussian"
    sidelobe_db: float = -6.0
    ping_rate_hz: float = 10.0
    rays_along_track: int = 3
    ray_oversampling: float = 1.0
    angular_grid_deg: float = 1.0
    mount_tolerance: float = 0.1
    acoustic: AcousticConfig = field(default_factory=AcousticConfig)

    def __post_init__(self) -> None:
        _check_common(self, 1000.0)
        _check_samples(
            "samples_per_side",
            self.samples_per_side,
            self.max_range - self.min_range,
            self.range_resolution,
        )
        _check_range(
            "along_track_beamwidth_deg", self.along_track_beamwidth_deg, 0.0, 30.0, lo_open=True
        )
        _check_range(
            "vertical_beamwidth_deg", self.vertical_beamwidth_deg, 0.0, 180.0, lo_open=True
        )
        _check_range("depression_deg", self.depression_deg, -30.0, 90.0)
        _check_choice("beam_pattern", self.beam_pattern, ("gaussian", "sinc", "rect"))
        _check_range("sidelobe_db", self.sidelobe_db, -200.0, 0.0)
        if not isinstance(self.rays_along_track, int) or not 1 <= self.rays_along_track <= 64:
            raise ValueError(
                f"rays_along_track = {self.rays_along_track!r}: allowed integer 1 .. 64"
            )
        _check_range("ray_oversampling", self.ray_oversampling, 0.25, 32.0)
        _check_range("angular_grid_deg", self.angular_grid_deg, 0.01, 5.0)

    @property
    def bin_width(self) -> float:
        """Range bin width, m."""
        return (self.max_range - self.min_range) / self.samples_per_side


@dataclass(frozen=True)
class FLSConfig(_RangeBins):
    """Forward-looking multibeam imaging sonar.

    n_beams across horizontal_fov_deg (beam centres uniformly spaced, bearing +ccw from body
    x, i.e. positive to port); n_bins range bins over [min_range, max_range];
    vertical_fov_deg sampled by rays_per_beam rays; tilt_deg: beam axis below horizontal;
    beamwidth_deg: horizontal −3 dB width of one beam (rays of a beam spread across it).
    """

    frequency_hz: float = 900e3
    max_range: float = 100.0
    min_range: float = 0.5
    n_bins: int = 1024
    n_beams: int = 512
    range_resolution: float = 0.0251
    horizontal_fov_deg: float = 90.0
    vertical_fov_deg: float = 20.0
    tilt_deg: float = 10.0
    beamwidth_deg: float = 1.0
    beam_pattern: BeamPattern = "gaussian"
    sidelobe_db: float = -30.0
    rays_per_beam: int = 16
    ping_rate_hz: float = 15.0
    mount_tolerance: float = 0.1
    acoustic: AcousticConfig = field(default_factory=lambda: AcousticConfig(source_level_db=206.0))

    def __post_init__(self) -> None:
        _check_polar(self)
        if not isinstance(self.n_beams, int) or not 1 <= self.n_beams <= 4096:
            raise ValueError(f"n_beams = {self.n_beams!r}: allowed integer 1 .. 4096")
        if not isinstance(self.rays_per_beam, int) or not 1 <= self.rays_per_beam <= 1024:
            raise ValueError(f"rays_per_beam = {self.rays_per_beam!r}: allowed integer 1 .. 1024")
        _check_range("horizontal_fov_deg", self.horizontal_fov_deg, 0.0, 180.0, lo_open=True)
        _check_range("vertical_fov_deg", self.vertical_fov_deg, 0.0, 90.0, lo_open=True)
        _check_range("beamwidth_deg", self.beamwidth_deg, 0.0, 30.0, lo_open=True)


@dataclass(frozen=True)
class MSISConfig(_RangeBins):
    """Mechanically scanned imaging sonar: one fan beam rotating about the site's z axis.

    step_deg: head step per ping; sector_deg: scanned sector (360 = full circle) centred
    on sector_center_deg (bearing from body x, ccw positive); n_bins over
    [min_range, max_range]; horizontal/vertical beamwidths (−3 dB) sampled by
    rays_horizontal × rays_vertical rays; tilt_deg: beam axis below horizontal.
    """

    frequency_hz: float = 700e3
    max_range: float = 50.0
    min_range: float = 0.3
    n_bins: int = 500
    range_resolution: float = 0.0075
    step_deg: float = 1.8
    sector_deg: float = 360.0
    sector_center_deg: float = 0.0
    horizontal_beamwidth_deg: float = 3.0
    vertical_beamwidth_deg: float = 35.0
    tilt_deg: float = 0.0
    beam_pattern: BeamPattern = "gaussian"
    sidelobe_db: float = -30.0
    rays_horizontal: int = 5
    rays_vertical: int = 64
    ping_rate_hz: float = 14.0
    mount_tolerance: float = 0.1
    acoustic: AcousticConfig = field(default_factory=lambda: AcousticConfig(source_level_db=206.0))

    def __post_init__(self) -> None:
        _check_polar(self)
        _check_range("step_deg", self.step_deg, 0.0, 90.0, lo_open=True)
        _check_range("sector_deg", self.sector_deg, 0.0, 360.0, lo_open=True)
        _check_range("sector_center_deg", self.sector_center_deg, -360.0, 360.0)
        _check_range(
            "horizontal_beamwidth_deg", self.horizontal_beamwidth_deg, 0.0, 30.0, lo_open=True
        )
        _check_range("vertical_beamwidth_deg", self.vertical_beamwidth_deg, 0.0, 90.0, lo_open=True)
        for name in ("rays_horizontal", "rays_vertical"):
            v = getattr(self, name)
            if not isinstance(v, int) or not 1 <= v <= 1024:
                raise ValueError(f"{name} = {v!r}: allowed integer 1 .. 1024")

    @property
    def n_steps(self) -> int:
        """Pings per scan (sector / step, rounded to nearest)."""
        return max(1, round(self.sector_deg / self.step_deg))


_DEEPEYE680D = SSSConfig(
    frequency_hz=680e3,
    max_range=50.0,
    samples_per_side=1000,
    range_resolution=0.01,
    along_track_beamwidth_deg=0.2,
    vertical_beamwidth_deg=50.0,
    depression_deg=20.0,
    ping_rate_hz=14.0,
)

PRESETS: dict[str, Any] = {
    "deepeye340d": SSSConfig(
        frequency_hz=340e3,
        max_range=75.0,
        samples_per_side=1000,
        range_resolution=0.015,
        along_track_beamwidth_deg=0.4,
        vertical_beamwidth_deg=50.0,
        depression_deg=20.0,
        ping_rate_hz=9.0,
    ),
    "deepeye680d": _DEEPEYE680D,
    "klein3500": SSSConfig(
        frequency_hz=400e3,
        max_range=75.0,
        samples_per_side=500,
        range_resolution=0.024,
        along_track_beamwidth_deg=0.4,
        vertical_beamwidth_deg=40.0,
        depression_deg=15.0,
        ping_rate_hz=9.0,
    ),
    # DeepEye 680D with every realism effect on; the calibration (docs/sonar_realism.md)
    # fits the RealismConfig levels to a real recording
    "deepeye680d_realistic": dataclasses.replace(
        _DEEPEYE680D,
        acoustic=AcousticConfig(
            realism=RealismConfig(range_cell_m=0.02, full_scale_db=158.5, volume_sv_db=-68.0)
        ),
    ),
    "blueview_p900_90": FLSConfig(),
    "msis": MSISConfig(),
}


def preset(name: str, **overrides: Any) -> Any:
    """A preset config by name with any fields overridden (validated again).

    ``acoustic`` may be given as an :class:`AcousticConfig` or as a dict of its fields;
    acoustic fields (e.g. ``source_level_db``, ``noise_level_db``, ``speckle``) and
    :class:`RealismConfig` fields (e.g. ``texture_db``; they switch realism on with its
    defaults if the preset has none; ``"off"`` sets an optional one to None, for TOML) may
    also be passed directly.
    """
    if name not in PRESETS:
        raise ValueError(
            f"sonar preset = {name!r} is unknown; allowed: {', '.join(sorted(PRESETS))}"
        )
    base = PRESETS[name]
    valid = {f.name for f in dataclasses.fields(base)}
    acoustic_fields = {f.name for f in dataclasses.fields(AcousticConfig)}
    realism_fields = {f.name for f in dataclasses.fields(RealismConfig)}
    ac = overrides.pop("acoustic", None)
    ac = (
        {f.name: getattr(ac, f.name) for f in dataclasses.fields(ac)}
        if isinstance(ac, AcousticConfig)
        else dict(ac or {})
    )
    for k in [k for k in overrides if k not in valid and k in acoustic_fields]:
        ac[k] = overrides.pop(k)
    rz = {k: overrides.pop(k) for k in [k for k in overrides if k in realism_fields]}
    rz = {k: (None if v == "off" else v) for k, v in rz.items()}  # TOML has no null
    bad = sorted(set(overrides) - valid)
    if bad:
        allowed = sorted(valid | acoustic_fields | realism_fields)
        raise ValueError(f"unknown field(s) {bad} for preset {name!r}; allowed: {allowed}")
    if rz:
        base_rz = ac.get("realism", base.acoustic.realism) or RealismConfig()
        ac["realism"] = dataclasses.replace(base_rz, **rz)
    if ac:
        overrides["acoustic"] = dataclasses.replace(base.acoustic, **ac)
    return dataclasses.replace(base, **overrides)

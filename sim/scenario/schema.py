"""Scenario files: TOML validated once into frozen dataclasses.

A scenario names the world (seabed, water, objects), one or more vehicles (each with its
start pose, mission, sonars, navigation sensors, front end and SLAM estimator), the
duration and the outputs. ``parse_scenario(dict)`` validates a decoded TOML table; every
mistake raises :class:`ScenarioError` (a ``ValueError``) whose message names the field
path (``vehicles[0].sonars[1].preset``), the bad value and what is allowed. Unknown keys
are rejected, so a typo never silently falls back to a default.

Units: metres, seconds, degrees only where the key says ``_deg``; world frame x east,
y north, z up (depth = -z). Annotated example: ``assets/scenarios/shipwreck-survey.toml``.
"""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from sim.scenario.seabed_check import check_scenario_seabed
from sim.sonar.config import PRESETS as _SONAR_PRESET_CONFIGS
from sim.sonar.config import SSSConfig
from sim.sonar.config import preset as sonar_preset
from sim.sonar.preset_file import calibrated_presets, is_preset_file, load_preset_file
from sim.world.objects import OBJECT_KINDS
from sim.world.seabed import SEABED_KINDS
from sim.world.vehicles import VEHICLE_KINDS
from slam.estimators import ESTIMATORS as _ESTIMATOR_MODULES
from slam.estimators import make_estimator
from slam.frontend.segmentation.methods import METHODS as _SEGMENTATION_METHODS
from slam.frontend.segmentation.presets import PRESETS as _SEGMENTATION_PRESETS
from slam.pipeline.config import TIMING_MODES

# --- names a scenario may use: each read from where the things are defined -------------
SONAR_PRESETS = tuple(_SONAR_PRESET_CONFIGS)
SIDESCAN_PRESETS = tuple(k for k, c in _SONAR_PRESET_CONFIGS.items() if isinstance(c, SSSConfig))
OBJECT_CLASSES = OBJECT_KINDS
FRONTEND_METHODS = (*_SEGMENTATION_METHODS, "none")
FRONTEND_PRESETS = ("auto", *_SEGMENTATION_PRESETS)
ESTIMATORS = (*_ESTIMATOR_MODULES, "none")
MISSION_TYPES = ("lawnmower", "loop", "line", "waypoints", "hold")
NAV_SENSORS = ("imu", "dvl", "depth", "ahrs", "gps")
VEHICLE_ASSETS = Path(__file__).resolve().parents[2] / "assets" / "vehicles"


class ScenarioError(ValueError):
    """A scenario value is wrong; the message names field, value and what is allowed."""


def _fail(path: str, value: Any, allowed: str) -> ScenarioError:
    return ScenarioError(f"scenario field '{path}': got {value!r}; allowed: {allowed}")


# ------------------------------------------------------------------ dataclasses ----------
@dataclass(frozen=True)
class ObjectSpec:
    """One seabed object of class ``cls``: base centre at position (x, y) world m on the
    seabed, heading yaw_deg (ccw from east), scale x the class's default size, burial =
    fraction of its height sunk into the seabed."""

    cls: str
    position: tuple[float, float]
    yaw_deg: float = 0.0
    scale: float = 1.0
    burial: float = 0.0
    name: str = ""


@dataclass(frozen=True)
class WaterSpec:
    temperature_c: float = 10.0
    salinity_psu: float = 35.0
    current_mps: tuple[float, float, float] = (0.0, 0.0, 0.0)
    current_variability: float = 0.0


@dataclass(frozen=True)
class WorldSpecConfig:
    """Seabed kind over a size_m[0] x size_m[1] square centred on the origin, at depth_m;
    relief_m: rms of gentle large-scale undulation (m, 0 = none)."""

    seabed: str = "flat"
    size_m: tuple[float, float] = (200.0, 200.0)
    depth_m: float = 30.0
    relief_m: float = 0.0
    seed: int | None = None
    grid_path: str = ""
    water: WaterSpec = field(default_factory=WaterSpec)
    objects: tuple[ObjectSpec, ...] = ()


@dataclass(frozen=True)
class MissionSpec:
    """Mission: lawnmower (area centre/size, heading, line spacing), loop/waypoints/line
    (explicit waypoints), hold (station keeping). Altitude (m above seabed) or depth (m).
    ``surface_at_s``: at this time the vehicle leaves its mission and surfaces where its
    navigation puts it (GPS fixes at the surface; a fix at the end of the run anchors the
    fleet's fused map, sim.runner.fleet). ``tie_line`` (lawnmower only): after the last
    line, fly straight back to the start of the first one — a tie line crossing every
    line at an oblique heading, re-imaging the site and closing the loop at the start.
    ``calibration_laps`` (lawnmower only, 0 = none): that many full turns of
    ``calibration_radius_m`` to starboard flown from ``calibration_at_m`` along the first
    line and back to it (a compass-calibration loop, sim.guidance.with_calibration_loop)."""

    type: str = "lawnmower"
    speed_mps: float = 1.5
    altitude_m: float | None = 8.0
    depth_m: float | None = None
    center: tuple[float, float] = (0.0, 0.0)
    size_m: tuple[float, float] = (100.0, 60.0)
    heading_deg: float = 0.0
    line_spacing_m: float | None = None
    waypoints: tuple[tuple[float, float], ...] = ()
    loops: int = 1
    surface_at_s: float | None = None
    tie_line: bool = False
    calibration_laps: int = 0
    calibration_radius_m: float = 20.0
    calibration_at_m: float = 0.0


@dataclass(frozen=True)
class SonarSpec:
    """preset: built-in preset name; overrides over it; source: the preset file the
    scenario named (a calibrated preset, whose overrides come first), "" for a built-in."""

    preset: str
    name: str
    overrides: Mapping[str, Any] = field(default_factory=dict)
    source: str = ""

    @property
    def is_sidescan(self) -> bool:
        return self.preset in SIDESCAN_PRESETS


@dataclass(frozen=True)
class NavSpec:
    """Navigation sensors: per sensor (imu, dvl, depth, ahrs, gps) an optional preset name
    and field overrides of sim.navigation's configs; coast_velocity_std m/s/sqrt(s).
    ``kind``: the vehicle whose own payload (``assets/vehicles/<kind>/navigation.toml``)
    is the base; a sensor table with a ``preset`` replaces the vehicle's sensor, one
    without overrides its fields. ``ahrs = { enabled = false }`` removes the compass."""

    sensors: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    coast_velocity_std: float = 0.05
    kind: str | None = None

    def merged_sensors(self) -> dict[str, dict[str, Any]]:
        """The vehicle's payload with this spec's sensor tables applied."""
        base: dict[str, dict[str, Any]] = {}
        if self.kind is not None:
            path = VEHICLE_ASSETS / self.kind / "navigation.toml"
            if path.exists():
                with path.open("rb") as f:
                    base = {k: dict(v) for k, v in tomllib.load(f).items()}
        for k, d in self.sensors.items():
            d = dict(d)
            base[k] = d if "preset" in d or k not in base else {**base[k], **d}
        return base

    def sensor_config(self, k: str):
        """The config of sensor ``k`` alone as this spec gives it (no vehicle payload),
        None for a disabled ahrs: validates the sensor's own fields."""
        return NavSpec(sensors={k: self.sensors[k]}).suite_config(only=k)

    def suite_config(self, only: str | None = None):
        """The sim.navigation.NavSuiteConfig this spec describes (``only``: return just
        that sensor's config)."""
        from sim.navigation import (
            AHRSConfig,
            DepthConfig,
            DVLConfig,
            GPSConfig,
            IMUConfig,
            NavSuiteConfig,
        )

        classes = {
            "imu": IMUConfig,
            "dvl": DVLConfig,
            "depth": DepthConfig,
            "ahrs": AHRSConfig,
            "gps": GPSConfig,
        }
        kw: dict[str, Any] = {}
        for k, d in self.merged_sensors().items():
            d = dict(d)
            if d.pop("enabled", True) is False:
                if k != "ahrs":
                    raise ValueError(f"only the ahrs can be disabled, not the {k}")
                kw[k] = None
                continue
            preset = d.pop("preset", None)
            cls = classes[k]
            base = NavSuiteConfig.__dataclass_fields__[k].default_factory()  # type: ignore[misc]
            kw[k] = cls.preset(preset, **d) if preset else replace(base, **d)
        if only is not None:
            return kw.get(only)
        return NavSuiteConfig(**kw, coast_velocity_std=self.coast_velocity_std)


@dataclass(frozen=True)
class FrontendSpec:
    method: str = "improved-otsu"
    preset: str = "auto"
    window_pings: int = 200
    hop_pings: int = 100
    min_area_m2: float = 0.15
    profile: str = "simulated"
    max_extent_m: float | None = None  # None: the profile's (inf, or REAL_SIDESCAN's 6 m)
    require_shadow: bool | None = None  # None: the profile's (False, or REAL_SIDESCAN's True)


#: [frontend] profile: "simulated" = the pipeline's defaults (MIRA normalization, no
#: area or extent filter); "real-sidescan" = the recorded-data front end of
#: ``undersea sss-slam`` (slam.pipeline.REAL_SIDESCAN's normalization, min_area_m2,
#: max_extent_m and first-return-edge rules), for images as textured as a real recording
FRONTEND_PROFILES = ("simulated", "real-sidescan")


@dataclass(frozen=True)
class SlamSpec:
    """estimator: name for slam.estimators.make_estimator; params passed through.
    timing: 'lagged' feeds each delayed side-scan observation to SLAM at the pose of its
    ping (the filter runs one window behind, see slam.pipeline.lagged); 'naive' applies it
    at detection time as if seen from the current pose (for comparison)."""

    estimator: str = "aekf"
    params: Mapping[str, Any] = field(default_factory=dict)
    timing: str = "lagged"
    association_gate_m: float = 3.0


@dataclass(frozen=True)
class VehicleSpec:
    name: str
    kind: str
    start_position: tuple[float, float, float]
    start_yaw_deg: float
    mission: MissionSpec
    sonars: tuple[SonarSpec, ...]
    nav: NavSpec
    frontend: FrontendSpec
    slam: SlamSpec


@dataclass(frozen=True)
class OutputSpec:
    recording: bool = True
    figures: bool = True
    log_sonar_every: int = 1


@dataclass(frozen=True)
class Scenario:
    name: str
    description: str
    seed: int
    duration_s: float
    control_dt: float
    world: WorldSpecConfig
    vehicles: tuple[VehicleSpec, ...]
    outputs: OutputSpec
    physics_dt: float = 0.01

    def with_overrides(self, seed: int | None = None, duration_s: float | None = None) -> Scenario:
        s = self
        if seed is not None:
            s = replace(s, seed=_int(seed, "seed", lo=0))
        if duration_s is not None:
            s = replace(s, duration_s=_num(duration_s, "duration_s", lo=0.0, lo_open=True))
        return s

    @property
    def world_seed(self) -> int:
        return self.seed if self.world.seed is None else self.world.seed


# ------------------------------------------------------------------ validators -----------
_TYPE_NAMES = {bool: "a boolean", int: "an integer", float: "a number", str: "a string"}


def _num(v, path, lo=None, hi=None, lo_open=False) -> float:
    if isinstance(v, bool) or not isinstance(v, int | float):
        raise _fail(path, v, "a number")
    v = float(v)
    if not math.isfinite(v):
        raise _fail(path, v, "a finite number")
    if lo is not None and (v < lo or (lo_open and v == lo)):
        raise _fail(
            path,
            v,
            f"a number {'>' if lo_open else '>='} {lo:g}"
            + (f" and <= {hi:g}" if hi is not None else ""),
        )
    if hi is not None and v > hi:
        raise _fail(path, v, f"a number <= {hi:g}" + (f" and >= {lo:g}" if lo is not None else ""))
    return v


def _int(v, path, lo=None, hi=None) -> int:
    if isinstance(v, bool) or not isinstance(v, int):
        raise _fail(path, v, "an integer")
    if lo is not None and v < lo:
        raise _fail(path, v, f"an integer >= {lo}")
    if hi is not None and v > hi:
        raise _fail(path, v, f"an integer <= {hi}")
    return int(v)


def _str(v, path, choices=None) -> str:
    if not isinstance(v, str):
        raise _fail(path, v, "one of " + ", ".join(choices) if choices else "a string")
    if choices is not None and v not in choices:
        raise _fail(path, v, ", ".join(choices))
    return v


def _bool(v, path) -> bool:
    if not isinstance(v, bool):
        raise _fail(path, v, "true or false")
    return v


def _vec(v, path, n, lo=None, hi=None, lo_open=False) -> tuple[float, ...]:
    if not isinstance(v, list | tuple) or len(v) != n:
        raise _fail(path, v, f"a list of {n} numbers")
    return tuple(_num(x, f"{path}[{i}]", lo, hi, lo_open) for i, x in enumerate(v))


def _table(v, path) -> dict:
    if not isinstance(v, Mapping):
        raise _fail(path, v, "a table")
    return dict(v)


def _check_keys(d: Mapping, path: str, allowed: tuple[str, ...]) -> None:
    for k in d:
        if k not in allowed:
            where = f"{path}.{k}" if path else k
            raise ScenarioError(
                f"scenario field '{where}': unknown key {k!r}; allowed keys here: {', '.join(allowed)}"
            )


def _scalar_overrides(v, path) -> dict[str, Any]:
    d = _table(v, path)
    for k, x in d.items():
        if isinstance(x, Mapping):
            raise _fail(f"{path}.{k}", x, "a number, string, boolean or list of numbers")
        if isinstance(x, float) and not math.isfinite(x):
            raise _fail(f"{path}.{k}", x, "a finite number")
    return d


# ------------------------------------------------------------------ sections -------------
def _parse_object(d, path) -> ObjectSpec:
    d = _table(d, path)
    _check_keys(d, path, ("class", "position", "yaw_deg", "scale", "burial", "name"))
    if "class" not in d:
        raise _fail(f"{path}.class", None, ", ".join(OBJECT_CLASSES))
    cls = _str(d["class"], f"{path}.class", OBJECT_CLASSES)
    if "position" not in d:
        raise _fail(f"{path}.position", None, "a list of 2 numbers [x, y] in m")
    pos = _vec(d["position"], f"{path}.position", 2)
    return ObjectSpec(
        cls=cls,
        position=pos,  # type: ignore[arg-type]
        yaw_deg=_num(d.get("yaw_deg", 0.0), f"{path}.yaw_deg", -360, 360),
        scale=_num(d.get("scale", 1.0), f"{path}.scale", 0.0, 100.0, lo_open=True),
        burial=_num(d.get("burial", 0.0), f"{path}.burial", 0.0, 0.9),
        name=_str(d.get("name", ""), f"{path}.name"),
    )


def _parse_world(d, path="world") -> WorldSpecConfig:
    d = _table(d, path)
    _check_keys(
        d,
        path,
        ("seabed", "size_m", "depth_m", "relief_m", "seed", "grid_path", "water", "objects"),
    )
    w = _table(d.get("water", {}), f"{path}.water")
    _check_keys(
        w, f"{path}.water", ("temperature_c", "salinity_psu", "current_mps", "current_variability")
    )
    water = WaterSpec(
        temperature_c=_num(w.get("temperature_c", 10.0), f"{path}.water.temperature_c", -2.0, 40.0),
        salinity_psu=_num(w.get("salinity_psu", 35.0), f"{path}.water.salinity_psu", 0.0, 45.0),
        current_mps=_vec(
            w.get("current_mps", [0.0, 0.0, 0.0]), f"{path}.water.current_mps", 3, -3.0, 3.0
        ),  # type: ignore[arg-type]
        current_variability=_num(
            w.get("current_variability", 0.0), f"{path}.water.current_variability", 0.0, 1.0
        ),
    )
    seabed = _str(d.get("seabed", "flat"), f"{path}.seabed", SEABED_KINDS)
    grid_path = _str(d.get("grid_path", ""), f"{path}.grid_path")
    if seabed == "grid" and not grid_path:
        raise _fail(
            f"{path}.grid_path", grid_path, "path to a .npy depth grid when seabed = 'grid'"
        )
    objs = d.get("objects", [])
    if not isinstance(objs, list):
        raise _fail(f"{path}.objects", objs, "an array of tables ([[world.objects]])")
    objects = tuple(_parse_object(o, f"{path}.objects[{i}]") for i, o in enumerate(objs))
    size = _vec(d.get("size_m", [200.0, 200.0]), f"{path}.size_m", 2, 1.0, 20000.0)
    for i, o in enumerate(objects):
        for ax in range(2):
            if abs(o.position[ax]) > size[ax] / 2:
                raise _fail(
                    f"{path}.objects[{i}].position[{ax}]",
                    o.position[ax],
                    f"inside the seabed, |value| <= {size[ax] / 2:g} m (world.size_m / 2)",
                )
    seed = d.get("seed")
    return WorldSpecConfig(
        seabed=seabed,
        size_m=size,  # type: ignore[arg-type]
        depth_m=_num(d.get("depth_m", 30.0), f"{path}.depth_m", 1.0, 11000.0),
        relief_m=_num(d.get("relief_m", 0.0), f"{path}.relief_m", 0.0, 50.0),
        seed=None if seed is None else _int(seed, f"{path}.seed", lo=0),
        grid_path=grid_path,
        water=water,
        objects=objects,
    )


def _parse_mission(d, path) -> MissionSpec:
    d = _table(d, path)
    _check_keys(
        d,
        path,
        (
            "type",
            "speed_mps",
            "altitude_m",
            "depth_m",
            "center",
            "size_m",
            "heading_deg",
            "line_spacing_m",
            "waypoints",
            "loops",
            "surface_at_s",
            "tie_line",
            "calibration_laps",
            "calibration_radius_m",
            "calibration_at_m",
        ),
    )
    typ = _str(d.get("type", "lawnmower"), f"{path}.type", MISSION_TYPES)
    wps = d.get("waypoints", [])
    if not isinstance(wps, list):
        raise _fail(f"{path}.waypoints", wps, "a list of [x, y] pairs in m")
    waypoints = tuple(_vec(p, f"{path}.waypoints[{i}]", 2) for i, p in enumerate(wps))
    if typ in ("loop", "waypoints", "line") and len(waypoints) < 2:
        raise _fail(f"{path}.waypoints", wps, f"at least 2 [x, y] waypoints for type = '{typ}'")
    alt = d.get("altitude_m", None if "depth_m" in d else 8.0)
    dep = d.get("depth_m")
    if alt is not None and dep is not None:
        raise ScenarioError(
            f"scenario field '{path}': both altitude_m and depth_m given; allowed: exactly one of them"
        )
    ls = d.get("line_spacing_m")
    return MissionSpec(
        type=typ,
        speed_mps=_num(d.get("speed_mps", 1.5), f"{path}.speed_mps", 0.0, 5.0, lo_open=True),
        altitude_m=None if alt is None else _num(alt, f"{path}.altitude_m", 0.5, 200.0),
        depth_m=None if dep is None else _num(dep, f"{path}.depth_m", 0.0, 11000.0),
        center=_vec(d.get("center", [0.0, 0.0]), f"{path}.center", 2),  # type: ignore[arg-type]
        size_m=_vec(
            d.get("size_m", [100.0, 60.0]), f"{path}.size_m", 2, 0.0, 20000.0, lo_open=True
        ),  # type: ignore[arg-type]
        heading_deg=_num(d.get("heading_deg", 0.0), f"{path}.heading_deg", -360.0, 360.0),
        line_spacing_m=None
        if ls is None
        else _num(ls, f"{path}.line_spacing_m", 0.0, 1000.0, lo_open=True),
        waypoints=waypoints,  # type: ignore[arg-type]
        loops=_int(d.get("loops", 1), f"{path}.loops", lo=1, hi=1000),
        surface_at_s=None
        if d.get("surface_at_s") is None
        else _num(d["surface_at_s"], f"{path}.surface_at_s", 0.0, lo_open=True),
        tie_line=_tie_line(d, typ, path),
        **_calibration_loop(d, typ, path),
    )


def _calibration_loop(d, typ: str, path: str) -> dict:
    laps = _int(d.get("calibration_laps", 0), f"{path}.calibration_laps", lo=0, hi=100)
    if laps and typ != "lawnmower":
        raise _fail(f"{path}.calibration_laps", laps, "0 unless type = 'lawnmower'")
    return {
        "calibration_laps": laps,
        "calibration_radius_m": _num(
            d.get("calibration_radius_m", 20.0),
            f"{path}.calibration_radius_m",
            0.0,
            1000.0,
            lo_open=True,
        ),
        "calibration_at_m": _num(
            d.get("calibration_at_m", 0.0), f"{path}.calibration_at_m", 0.0, 20000.0
        ),
    }


def _tie_line(d, typ: str, path: str) -> bool:
    tie = _bool(d.get("tie_line", False), f"{path}.tie_line")
    if tie and typ != "lawnmower":
        raise _fail(f"{path}.tie_line", tie, "true only with type = 'lawnmower'")
    return tie


def _parse_frontend(d, path, base: FrontendSpec) -> FrontendSpec:
    d = _table(d, path)
    _check_keys(
        d,
        path,
        (
            "method",
            "preset",
            "window_pings",
            "hop_pings",
            "min_area_m2",
            "profile",
            "max_extent_m",
            "require_shadow",
        ),
    )
    fe = FrontendSpec(
        method=_str(d.get("method", base.method), f"{path}.method", FRONTEND_METHODS),
        preset=_str(d.get("preset", base.preset), f"{path}.preset", FRONTEND_PRESETS),
        window_pings=_int(
            d.get("window_pings", base.window_pings), f"{path}.window_pings", 8, 10000
        ),
        hop_pings=_int(d.get("hop_pings", base.hop_pings), f"{path}.hop_pings", 1, 10000),
        min_area_m2=_num(d.get("min_area_m2", base.min_area_m2), f"{path}.min_area_m2", 0.0),
        profile=_str(d.get("profile", base.profile), f"{path}.profile", FRONTEND_PROFILES),
        max_extent_m=(
            base.max_extent_m
            if d.get("max_extent_m") is None
            else _num(d["max_extent_m"], f"{path}.max_extent_m", 0.0, lo_open=True)
        ),
        require_shadow=(
            base.require_shadow
            if d.get("require_shadow") is None
            else _bool(d["require_shadow"], f"{path}.require_shadow")
        ),
    )
    if fe.hop_pings > fe.window_pings:
        raise _fail(
            f"{path}.hop_pings", fe.hop_pings, f"an integer <= window_pings ({fe.window_pings})"
        )
    return fe


def _parse_slam(d, path, base: SlamSpec) -> SlamSpec:
    d = _table(d, path)
    _check_keys(d, path, ("estimator", "params", "timing", "association_gate_m"))
    params = dict(base.params)
    params.update(_scalar_overrides(d.get("params", {}), f"{path}.params"))
    estimator = _str(d.get("estimator", base.estimator), f"{path}.estimator", ESTIMATORS)
    _check_estimator_params(estimator, params, f"{path}.params")
    return SlamSpec(
        estimator=estimator,
        params=params,
        timing=_str(d.get("timing", base.timing), f"{path}.timing", TIMING_MODES),
        association_gate_m=_num(
            d.get("association_gate_m", base.association_gate_m),
            f"{path}.association_gate_m",
            0.0,
            100.0,
            lo_open=True,
        ),
    )


def _check_estimator_params(name: str, params: Mapping[str, Any], path: str) -> None:
    """Validate ``slam.params`` against the estimator's own config by building it once
    (a typo is an error naming the field; an optional dependency missing, as gtsam for
    iSAM2, is reported at run time instead)."""
    if name == "none":
        if params:
            raise _fail(path, dict(params), "no params for estimator 'none'")
        return
    try:
        make_estimator(name, x0=np.zeros(3), P0=np.eye(3) * 0.01, **dict(params))
    except ImportError:
        return
    except TypeError as exc:
        m = re.search(r"unexpected keyword argument '(\w+)'", str(exc))
        key = m.group(1) if m else "?"
        raise ScenarioError(
            f"scenario field '{path}.{key}': not a parameter of estimator {name!r} ({exc})"
        ) from exc
    except ValueError as exc:
        raise ScenarioError(f"scenario field '{path}': {exc}") from exc


def _parse_sonar(d, path) -> SonarSpec:
    d = _table(d, path)
    _check_keys(d, path, ("preset", "name", "overrides"))
    allowed = ", ".join((*SONAR_PRESETS, *calibrated_presets())) + " or a preset .toml path"
    if "preset" not in d:
        raise _fail(f"{path}.preset", None, allowed)
    preset = _str(d["preset"], f"{path}.preset")
    base, source = {}, ""
    if preset not in SONAR_PRESETS:
        if not is_preset_file(preset):
            raise _fail(f"{path}.preset", preset, allowed)
        try:
            pf = load_preset_file(preset)
        except ValueError as exc:
            raise ScenarioError(f"scenario field '{path}.preset': {exc}") from exc
        preset, base, source = pf.base, pf.overrides, pf.source
    name = _str(d.get("name", "sss" if preset in SIDESCAN_PRESETS else preset), f"{path}.name")
    if not name.isidentifier():
        raise _fail(f"{path}.name", name, "an identifier (letters, digits, underscore)")
    overrides = {**base, **_scalar_overrides(d.get("overrides", {}), f"{path}.overrides")}
    _check_sonar_overrides(preset, overrides, f"{path}.overrides")
    return SonarSpec(preset=preset, name=name, overrides=overrides, source=source)


def _check_sonar_overrides(preset: str, overrides: dict, path: str) -> None:
    """Validate overrides against the sonar's own config dataclass (its ValueError names
    the field and the allowed range)."""
    try:
        sonar_preset(preset, **dict(overrides))
    except (ValueError, TypeError) as exc:
        raise ScenarioError(f"scenario field '{path}': {exc}") from exc


def _parse_nav(d, path, kind: str | None = None) -> NavSpec:
    d = _table(d, path)
    _check_keys(d, path, ("coast_velocity_std", *NAV_SENSORS))
    sensors = {k: _scalar_overrides(d[k], f"{path}.{k}") for k in NAV_SENSORS if k in d}
    spec = NavSpec(
        sensors=sensors,
        coast_velocity_std=_num(
            d.get("coast_velocity_std", 0.05), f"{path}.coast_velocity_std", 0.0, 10.0
        ),
        kind=kind,
    )
    try:
        import sim.navigation  # noqa: F401
    except ImportError:  # navigation package not available: checked again at run time
        return spec
    for k in sensors:
        try:
            spec.sensor_config(k)
        except (ValueError, TypeError) as exc:
            raise ScenarioError(f"scenario field '{path}.{k}': {exc}") from exc
    try:
        spec.suite_config()
    except (ValueError, TypeError) as exc:
        raise ScenarioError(f"scenario field '{path}': {exc}") from exc
    return spec


def _check_dvl_lock(v: VehicleSpec, path: str, world: WorldSpecConfig) -> None:
    """A mission flown entirely above (or below) the DVL's bottom-lock window leaves dead
    reckoning without velocity for the whole run: reject it, naming both fields."""
    try:
        dvl = v.nav.suite_config().dvl
    except ImportError:  # navigation package not available: checked at run time
        return
    m = v.mission
    if m.altitude_m is not None:
        alt, where = m.altitude_m, f"{path}.mission.altitude_m"
    elif m.depth_m is not None:
        alt, where = world.depth_m - m.depth_m, f"{path}.mission.depth_m"
    else:
        return
    if not dvl.min_altitude <= alt <= dvl.max_altitude:
        raise _fail(
            where,
            m.altitude_m if m.altitude_m is not None else m.depth_m,
            f"a mission altitude inside the DVL's bottom-lock window "
            f"[{dvl.min_altitude:g}, {dvl.max_altitude:g}] m ({path}.nav.dvl min_altitude / "
            f"max_altitude; the flight would be at {alt:g} m above a {world.depth_m:g} m "
            "seabed): dead reckoning would have no velocity for the whole run",
        )


def _parse_vehicle(
    d, path, fe_base: FrontendSpec, slam_base: SlamSpec, world: WorldSpecConfig
) -> VehicleSpec:
    d = _table(d, path)
    _check_keys(d, path, ("kind", "name", "start", "mission", "sonars", "nav", "frontend", "slam"))
    if "kind" not in d:
        raise _fail(f"{path}.kind", None, ", ".join(VEHICLE_KINDS))
    kind = _str(d["kind"], f"{path}.kind", VEHICLE_KINDS)
    name = _str(d.get("name", kind), f"{path}.name")
    if not name.isidentifier():
        raise _fail(f"{path}.name", name, "an identifier (letters, digits, underscore)")
    start = _table(d.get("start", {}), f"{path}.start")
    _check_keys(start, f"{path}.start", ("position", "yaw_deg"))
    pos = _vec(start.get("position", [0.0, 0.0, -5.0]), f"{path}.start.position", 3)
    for ax in range(2):
        if abs(pos[ax]) > world.size_m[ax] / 2:
            raise _fail(
                f"{path}.start.position[{ax}]",
                pos[ax],
                f"|value| <= {world.size_m[ax] / 2:g} m (world.size_m / 2)",
            )
    if not -world.depth_m < pos[2] <= 0.0:
        raise _fail(
            f"{path}.start.position[2]",
            pos[2],
            f"a z in (-{world.depth_m:g}, 0] m (below the surface, above the seabed)",
        )
    sonars_raw = d.get("sonars", [])
    if not isinstance(sonars_raw, list):
        raise _fail(f"{path}.sonars", sonars_raw, "an array of tables ([[vehicles.sonars]])")
    sonars = tuple(_parse_sonar(s, f"{path}.sonars[{i}]") for i, s in enumerate(sonars_raw))
    names = [s.name for s in sonars]
    for i, n in enumerate(names):
        if names.index(n) != i:
            raise _fail(
                f"{path}.sonars[{i}].name", n, "a name not used by another sonar of this vehicle"
            )
    spec = VehicleSpec(
        name=name,
        kind=kind,
        start_position=pos,  # type: ignore[arg-type]
        start_yaw_deg=_num(start.get("yaw_deg", 0.0), f"{path}.start.yaw_deg", -360.0, 360.0),
        mission=_parse_mission(d.get("mission", {}), f"{path}.mission"),
        sonars=sonars,
        nav=_parse_nav(d.get("nav", {}), f"{path}.nav", kind),
        frontend=_parse_frontend(d.get("frontend", {}), f"{path}.frontend", fe_base),
        slam=_parse_slam(d.get("slam", {}), f"{path}.slam", slam_base),
    )
    _check_dvl_lock(spec, path, world)
    return spec


TOP_KEYS = (
    "name",
    "description",
    "seed",
    "duration_s",
    "control_dt",
    "physics_dt",
    "world",
    "vehicles",
    "frontend",
    "slam",
    "outputs",
)


def parse_scenario(data: Mapping[str, Any]) -> Scenario:
    """Validate a decoded scenario table into a :class:`Scenario` (raises ScenarioError).

    Top-level ``[frontend]`` and ``[slam]`` are defaults every vehicle inherits; a
    vehicle's own ``[vehicles.frontend]`` / ``[vehicles.slam]`` override them key by key.
    """
    d = _table(data, "<scenario>")
    _check_keys(d, "", TOP_KEYS)
    if "world" not in d:
        raise _fail("world", None, "a [world] table")
    world = _parse_world(d["world"])
    fe_base = _parse_frontend(d.get("frontend", {}), "frontend", FrontendSpec())
    slam_base = _parse_slam(d.get("slam", {}), "slam", SlamSpec())
    vs = d.get("vehicles")
    if not isinstance(vs, list) or not vs:
        raise _fail("vehicles", vs, "a non-empty array of tables ([[vehicles]])")
    vehicles = tuple(
        _parse_vehicle(v, f"vehicles[{i}]", fe_base, slam_base, world) for i, v in enumerate(vs)
    )
    names = [v.name for v in vehicles]
    for i, n in enumerate(names):
        if names.index(n) != i:
            raise _fail(
                f"vehicles[{i}].name", n, "a name not used by another vehicle (set vehicles.name)"
            )
    o = _table(d.get("outputs", {}), "outputs")
    _check_keys(o, "outputs", ("recording", "figures", "log_sonar_every"))
    outputs = OutputSpec(
        recording=_bool(o.get("recording", True), "outputs.recording"),
        figures=_bool(o.get("figures", True), "outputs.figures"),
        log_sonar_every=_int(o.get("log_sonar_every", 1), "outputs.log_sonar_every", 1, 10000),
    )
    seed = _int(d.get("seed", 0), "seed", lo=0)
    check_scenario_seabed(world, vehicles, seed if world.seed is None else world.seed)
    control_dt = _num(d.get("control_dt", 0.05), "control_dt", 0.001, 1.0)
    physics_dt = _num(d.get("physics_dt", 0.01), "physics_dt", 0.0001, 0.05)
    ratio = control_dt / physics_dt
    if abs(ratio - round(ratio)) > 1e-6:
        raise _fail("control_dt", control_dt, f"a whole multiple of physics_dt = {physics_dt:g} s")
    return Scenario(
        name=_str(d.get("name", "unnamed"), "name"),
        description=_str(d.get("description", ""), "description"),
        seed=seed,
        duration_s=_num(d.get("duration_s", 60.0), "duration_s", 0.0, 1e6, lo_open=True),
        control_dt=control_dt,
        world=world,
        vehicles=vehicles,
        outputs=outputs,
        physics_dt=physics_dt,
    )


# ------------------------------------------------------------------ loading --------------
def builtin_dir() -> Path:
    """Folder of the built-in scenario files (``assets/scenarios``)."""
    return Path(__file__).resolve().parents[2] / "assets" / "scenarios"


def builtin_scenarios() -> dict[str, Path]:
    """Built-in scenario name -> file, sorted by name."""
    d = builtin_dir()
    return {p.stem: p for p in sorted(d.glob("*.toml"))} if d.is_dir() else {}


def set_dotted(data: dict, key: str, value: Any) -> dict:
    """Return a deep copy of ``data`` with one field set, for sweeps and overrides.

    Keys are dotted paths; list items by ``[i]`` or ``.i``: ``slam.estimator`` (the default
    every vehicle inherits), ``vehicles[0].slam.estimator`` = ``vehicles.0.slam.estimator``.
    The result still goes through :func:`parse_scenario`, so bad values fail there with the
    usual message."""
    import copy
    import re

    if not re.fullmatch(r"[A-Za-z_]\w*(\[\d+\])?(\.(\d+|[A-Za-z_]\w*(\[\d+\])?))*", key):
        raise ScenarioError(
            f"override key {key!r}: allowed: dotted field names like 'vehicles[0].slam.estimator'"
        )
    tokens: list[str | int] = []
    for part in key.split("."):
        m = re.fullmatch(r"(\w+?)(?:\[(\d+)\])?", part)
        assert m is not None
        tokens.append(int(m.group(1)) if m.group(1).isdigit() else m.group(1))
        if m.group(2) is not None:
            tokens.append(int(m.group(2)))
    out = copy.deepcopy(data)
    cur: Any = out
    for j, tok in enumerate(tokens):
        last = j == len(tokens) - 1
        if isinstance(tok, int):
            if not isinstance(cur, list) or tok >= len(cur):
                raise ScenarioError(f"override key {key!r}: item {tok} does not exist")
        elif not isinstance(cur, dict):
            raise ScenarioError(f"override key {key!r}: {tok!r} is not inside a table")
        if last:
            cur[tok] = value
        elif isinstance(tok, int):
            cur = cur[tok]
        else:
            nxt = tokens[j + 1]
            cur = cur.setdefault(tok, [] if isinstance(nxt, int) else {})
    return out


def load_scenario_dict(name_or_path: str | Path) -> dict:
    """Decoded TOML of a built-in scenario name or a file path."""
    p = Path(name_or_path)
    builtins = builtin_scenarios()
    if str(name_or_path) in builtins:
        p = builtins[str(name_or_path)]
    elif not p.is_file():
        raise ScenarioError(
            f"scenario {str(name_or_path)!r}: not a file and not a built-in; allowed: a .toml path or one of "
            + ", ".join(builtins)
        )
    try:
        with open(p, "rb") as f:
            return tomllib.load(f)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"scenario file {str(p)!r}: invalid TOML: {exc}") from exc
    except UnicodeDecodeError as exc:
        raise ScenarioError(
            f"scenario file {str(p)!r}: byte {exc.start} is not UTF-8 ({exc.reason}); "
            "allowed: a UTF-8 text file (TOML requires UTF-8)"
        ) from exc
    except OSError as exc:
        raise ScenarioError(f"scenario file {str(p)!r}: cannot read it ({exc.strerror})") from exc


def load_scenario(name_or_path: str | Path, overrides: Mapping[str, Any] | None = None) -> Scenario:
    """Load and validate a scenario by built-in name or path, with optional dotted overrides."""
    data = load_scenario_dict(name_or_path)
    for k, v in (overrides or {}).items():
        data = set_dotted(data, k, v)
    return parse_scenario(data)

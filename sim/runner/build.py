"""Building a scenario run: the world, each vehicle's autopilot, nav suite, sonars and
its sonar-to-SLAM pipeline (slam.pipeline.SonarSlam), from a validated Scenario.

Public names used by the envs and the dataset exporter: :func:`world_spec_from_scenario`,
:func:`mission_for`, :func:`pipeline_config`, :func:`sonar_geometry`, :func:`make_sonar`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from sim.guidance import Mission, hold, lawnmower, loop, straight_line, with_calibration_loop
from sim.scenario.schema import Scenario, SonarSpec, VehicleSpec
from sim.scenario.seabed_check import seabed_spec
from sim.sonar import ForwardLookingSonar, MSISSonar, SideScanSonar, preset
from sim.viz.rerun_log import class_id
from sim.world import (
    OBJECT_CLASSES,
    CurrentSpec,
    ObjectSpec,
    SonarWater,
    Water,
    WorldSpec,
)
from sim.world import VehicleSpec as WorldVehicleSpec
from slam.estimators.nav_bias import NavBiasModel, NavBiasSlam
from slam.pipeline import (
    DetectionTally,
    EstimatorSpec,
    PipelineConfig,
    SonarGeometry,
    SonarSlam,
    build_estimator,
    make_frontend,
    with_real_sidescan_rules,
)


def world_spec_from_scenario(scn: Scenario) -> WorldSpec:
    """sim.world.WorldSpec for a scenario (seabed, water, current, objects, vehicles)."""
    w = scn.world
    seabed = seabed_spec(w, scn.world_seed)
    water = Water.from_ts(w.water.temperature_c, w.water.salinity_psu, reference_depth_m=w.depth_m)
    cur = CurrentSpec(
        velocity=w.water.current_mps,
        variation=w.water.current_variability,
        seed=scn.world_seed + 1,
    )
    objects = []
    for i, o in enumerate(w.objects):
        size_o = (
            tuple(s * o.scale for s in OBJECT_CLASSES[o.cls].default_size)
            if o.scale != 1.0
            else None
        )
        objects.append(
            ObjectSpec(
                kind=o.cls,
                position_xy=o.position[:2],
                yaw_deg=o.yaw_deg,
                size=size_o,
                burial=o.burial,
                seed=scn.world_seed * 1000 + i,
            )
        )
    vehicles = tuple(
        WorldVehicleSpec(
            v.kind, name=v.name, position=v.start_position, rpy_deg=(0.0, 0.0, v.start_yaw_deg)
        )
        for v in scn.vehicles
    )
    return WorldSpec(
        seabed=seabed,
        water=water,
        vehicles=vehicles,
        objects=tuple(objects),
        current=cur,
        timestep=scn.physics_dt,
    )


def mission_for(v: VehicleSpec, swath: float) -> Mission:
    """sim.guidance Mission from a vehicle's mission spec (swath for lawnmower spacing)."""
    m = v.mission
    kw = {"depth": m.depth_m, "altitude": m.altitude_m}
    heading = math.radians(m.heading_deg)
    if m.type == "lawnmower":
        mission = lawnmower(
            m.center,
            m.size_m[0],
            m.size_m[1],
            max(swath, 1.0),
            0.2,
            heading=heading,
            speed=m.speed_mps,
            spacing=m.line_spacing_m,
            **kw,
        )
        if m.tie_line:  # back to the first line's start across all lines
            mission = replace(
                mission, waypoints=np.vstack([mission.waypoints, mission.waypoints[:1]])
            )
        if m.calibration_laps:  # compass-calibration loop on the first line
            mission = with_calibration_loop(
                mission, m.calibration_at_m, m.calibration_radius_m, m.calibration_laps
            )
        return mission
    if m.type == "loop":
        return loop(np.array(m.waypoints), laps=m.loops, speed=m.speed_mps, **kw)
    if m.type == "waypoints":
        return Mission(
            "waypoints", np.array(m.waypoints, float), m.speed_mps, m.depth_m, m.altitude_m
        )
    if m.type == "line":
        return straight_line(m.waypoints[0], m.waypoints[-1], speed=m.speed_mps, **kw)
    return hold(m.center, duration=1e9, **kw)


def pipeline_config(v: VehicleSpec) -> PipelineConfig:
    """A vehicle's [frontend] and [slam] tables as the pipeline's config. The runner has
    always segmented side-scan windows without the ground-area speckle filter, so
    ``frontend.min_area_m2`` is not applied (kept so the built-in scenarios' numbers
    hold; see docs/pipeline.md). ``frontend.profile = "real-sidescan"`` segments the
    side-scan like recorded data (slam.pipeline.REAL_SIDESCAN: column-median
    normalization, the ``min_area_m2`` speckle filter, single regions longer than
    ``max_extent_m`` dropped as seabed patches, the first-return edge rules, objects
    without a shadow dropped): one front end for a real recording and for the calibrated
    presets' textured images. ``frontend.max_extent_m`` (m) replaces the profile's
    extent rule (a scenario with objects longer than 6 m keeps them);
    ``frontend.require_shadow`` the profile's shadow rule (objects and each of their
    regions need a shadow: slam.frontend.sidescan_windows; the textured seabed of a
    calibrated preset, docs/sonar_realism.md).

    Start covariance: a run starts SLAM and the dead reckoner at the true start pose, and
    the dead reckoner's covariance, handed on in the matched odometry Q, carries the
    navigation's uncertainty, so the heading starts with zero variance. The one error
    that covariance leaves out (sim.navigation.dead_reckoning: extrapolation of the held
    samples) is the launch from rest: the held DVL velocity lags the acceleration by up
    to half a ping interval, an along-track error up to speed / (2 f_DVL) (0.15 m for
    the alister9, 0.03 m for the SAGA); that is the start position's 1-sigma. The
    pipeline's generic default (0.1 m, 0.5°) is uncertainty the run's errors never
    have (pose NEES far below 3 until the navigation's own dominates)."""
    fe, sl = v.frontend, v.slam
    launch_lag = v.mission.speed_mps / (2.0 * v.nav.suite_config(only="dvl").rate_hz)
    cfg = PipelineConfig(
        method=fe.method,
        preset=fe.preset,
        window_pings=fe.window_pings,
        hop_pings=fe.hop_pings,
        merge_radius_m=sl.association_gate_m,
        timing=sl.timing,
        pose0_var_xy_m2=launch_lag**2,
        pose0_sigma_yaw_deg=0.0,
    )
    if fe.profile == "real-sidescan":
        cfg = replace(with_real_sidescan_rules(cfg), min_area_m2=fe.min_area_m2)
    if fe.max_extent_m is not None:
        cfg = replace(cfg, max_extent_m=fe.max_extent_m)
    if fe.require_shadow is not None:
        cfg = replace(cfg, require_shadow=fe.require_shadow)
    return cfg


@dataclass
class SonarRuntime:
    """One sonar of a running vehicle: its simulator, ping schedule and geometry."""

    spec: SonarSpec
    kind: str  # "sss" | "fls" | "msis"
    sonar: object
    period: float
    rng: np.random.Generator
    geometry: SonarGeometry
    next_t: float = 0.0
    msis_k: int = 0
    frames: int = 0
    sss_pings: list = field(default_factory=list)  # (pose_true, ground range, intensity)


@dataclass
class VehicleRuntime:
    """One running vehicle: handles, its pipeline, truth and scores."""

    spec: VehicleSpec
    handle: object
    autopilot: object
    nav: object
    slam: SonarSlam
    sonars: list[SonarRuntime]
    tally: DetectionTally = field(default_factory=DetectionTally)
    true_t: list = field(default_factory=list)
    true_pose: list = field(default_factory=list)  # [x, y, z, yaw]
    gps_fixes: list = field(default_factory=list)  # (t s, xy (2,) world m) while surfaced
    surfacing: bool = False  # left the mission for the surface (mission.surface_at_s)
    speed: float = 0.0
    altitude_nav: float = float("nan")

    @property
    def lagged(self):
        """The pipeline's fixed-lag feeder (None without an estimator)."""
        return self.slam.lagged


def sonar_geometry(world, vehicle_name: str, sp: SonarSpec, son) -> SonarGeometry:
    """The pipeline's geometry of a built sonar (mounting from the vehicle's site)."""
    cfg = son.config
    h = world.vehicles[vehicle_name]
    ac = cfg.acoustic
    if sp.is_sidescan:
        return SonarGeometry(
            "sss",
            son.ranges,
            along_track_beamwidth_deg=cfg.along_track_beamwidth_deg,
            log_compressed=ac.log_compression,
            dynamic_range_db=ac.dynamic_range_db,
        )
    kind = "msis" if sp.preset == "msis" else "fls"
    if kind == "msis":
        bearings = son.head_angles()
        cell = math.radians(max(cfg.horizontal_beamwidth_deg, cfg.step_deg))
    else:
        bearings = son.bearings
        cell = math.radians(max(cfg.beamwidth_deg, cfg.horizontal_fov_deg / cfg.n_beams))
    return SonarGeometry(
        kind,
        son.ranges,
        bearings,
        mounting_xy=tuple(world.model.site_pos[h.site_ids[kind]][:2]),
        bin_width=cfg.bin_width,
        angular_cell=cell,
        log_compressed=ac.log_compression,
        dynamic_range_db=ac.dynamic_range_db,
    )


def make_sonar(
    world, vehicle_name: str, sp: SonarSpec, rng, *, linear: bool = False
) -> SonarRuntime:
    """Build one scenario sonar on a vehicle of ``world``; ``linear``: without the preset's
    log compression (linear intensity out, as the dataset exporter wants)."""
    cfg = preset(sp.preset, **dict(sp.overrides))
    if linear:
        cfg = replace(cfg, acoustic=replace(cfg.acoustic, log_compression=False))
    h = world.vehicles[vehicle_name]
    common = (world.model, world.data)
    kw = {
        "geom_object_id": world.geom_object_id,
        "geom_reflectivity": world.geom_reflectivity,
        "water": SonarWater(world.water),
        "static_mesh": world.static_mesh(),
    }
    if sp.is_sidescan:
        son = SideScanSonar(
            cfg, *common, (h.site_ids["sss_port"], h.site_ids["sss_starboard"]), **kw
        )
        kind = "sss"
    elif sp.preset == "msis":
        son, kind = MSISSonar(cfg, *common, h.site_ids["msis"], **kw), "msis"
    else:
        son, kind = ForwardLookingSonar(cfg, *common, h.site_ids["fls"], **kw), "fls"
    geom = sonar_geometry(world, vehicle_name, sp, son)
    return SonarRuntime(sp, kind, son, 1.0 / cfg.ping_rate_hz, rng, geom)


def object_class_of(world):
    """object id -> display class id (side-scan overlays)."""
    names = {o.id: o.class_name for o in world.objects}

    def class_of(oid: int) -> int:
        name = names.get(oid)
        if name is None:
            return class_id("detection")
        return class_id(name if name != "tree_branch" else "branch")

    return class_of


def nav_bias_model(vs: VehicleSpec) -> NavBiasModel | None:
    """The navigation bias states SLAM carries for this vehicle (slam.estimators.nav_bias),
    or None. On for the AEKF with a compass-aided heading (the MEMS AHRS payloads, whose
    drift is the compass deviation, its slow drift and the DVL's constants): their
    priors are the sensors' own datasheet errors. Then the run hands SLAM each odometry
    increment's own covariance (``NavSuiteConfig.matched_odometry_covariance = False``,
    :func:`nav_suite_config`): the states carry the correlated errors the matched Q
    stood in for. Off for other estimators and for a gyro (FOG) heading."""
    cfg = vs.nav.suite_config()
    if vs.slam.estimator != "aekf" or not cfg.aided:
        return None
    ah, dvl = cfg.ahrs, cfg.dvl
    return NavBiasModel(
        hard_iron_std=ah.hard_iron_std,
        soft_iron_std=ah.soft_iron_std,
        drift_std=ah.drift_std,
        drift_tau_s=ah.drift_tau_s,
        scale_factor_std=dvl.scale_factor_std,
        misalignment_std=dvl.misalignment_std,
        velocity_bias_std=dvl.velocity_bias_std,
    )


def nav_suite_config(vs: VehicleSpec):
    """The vehicle's NavSuiteConfig for a run: the matched odometry Q unless SLAM carries
    the navigation bias states (:func:`nav_bias_model`)."""
    cfg = vs.nav.suite_config()
    if nav_bias_model(vs) is not None:
        cfg = replace(cfg, matched_odometry_covariance=False)
    return cfg


def make_pipeline(world, vs: VehicleSpec, sonars: list[SonarRuntime], rng) -> SonarSlam:
    """The vehicle's SonarSlam: a front end per sonar, the scenario's estimator at the
    start pose (none when ``slam.estimator = "none"``), with the navigation bias states
    of :func:`nav_bias_model` where they apply."""
    cfg = pipeline_config(vs)
    class_of = object_class_of(world)
    frontends = {s.spec.name: make_frontend(s.geometry, cfg, class_of=class_of) for s in sonars}
    pose0 = np.array([vs.start_position[0], vs.start_position[1], math.radians(vs.start_yaw_deg)])
    est = None
    if vs.slam.estimator != "none" and sonars:
        est = build_estimator(EstimatorSpec(vs.slam.estimator, vs.slam.params), pose0, cfg, rng)
        bias = nav_bias_model(vs)
        if bias is not None:
            est = NavBiasSlam(est, bias, t0=world.time)
    return SonarSlam(frontends, est, cfg, t0=world.time, pose0=pose0)

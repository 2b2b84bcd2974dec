"""The scenario loop: physics, navigation sensors, sonars at their ping rates, the front
end on each sonar frame, observations into SLAM; recording, metrics and figures.

One control tick (``scenario.control_dt``): every vehicle's autopilot (sim.guidance)
turns its true state into a body wrench demand (guidance uses the true state: the
vehicles' own navigation filters are not modelled; SLAM runs beside it). Physics then
advances in whole physics steps to each sonar ping due inside the tick; at each ping the
vehicle's nav suite is polled and its odometry cut at the ping time, so every sonar
observation has an odometry node at exactly its time. Side-scan pings accumulate into
waterfall windows (slam.frontend.sidescan_windows), FLS frames are segmented one by one, MSIS
pings build sector scans. Observations reach SLAM through a time-ordered fixed-lag
feeder (sim.runner.lagged): each update happens at the pose of its ping.

Outputs (``run_scenario``): ``DIR/recording.rrd`` (sim.viz.rerun_log), ``DIR/metrics.json``
(sim.runner.metrics; ``"complete": false`` after Ctrl-C), ``DIR/trajectory_map.png`` and
``DIR/sss_mosaic.png``. The directory is staged and renamed at the end (sim.runner.output).
Everything in metrics.json except its ``"timing"`` section (wall-clock: per-stage seconds
and the real-time factor) depends only on the scenario and the seed.
"""

from __future__ import annotations

import math
import os
import sys
import time
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sim.runner.fls_msis import FLS_FRONTEND, MSIS_FRONTEND, PolarFrontend
from sim.runner.lagged import LaggedSlam, apply_increment
from sim.runner.metrics import detection_metrics, landmark_metrics, pose_metrics
from sim.runner.output import RunDirectory
from sim.scenario.schema import Scenario, SonarSpec, VehicleSpec
from slam.frontend.sidescan_windows import (
    PingRecord,
    SidescanProcessor,
    make_sss_prepare,
)
from slam.types import Odometry

# ----------------------------------------------------------------------- building -------


def world_spec_from_scenario(scn: Scenario):
    """sim.world.WorldSpec for a scenario (seabed, water, current, objects, vehicles)."""
    from sim.world import CurrentSpec, ObjectSpec, SeabedSpec, VehicleSpec, Water, WorldSpec

    w = scn.world
    size = max(w.size_m)
    res = float(np.clip(size / 400.0, 0.25, 2.0))
    seabed = SeabedSpec(
        kind=w.seabed,
        size_xy=w.size_m,
        resolution=res,
        depth=w.depth_m,
        seed=scn.world_seed,
        grid_path=w.grid_path or None,
        relief=w.relief_m,
    )
    water = Water.from_ts(w.water.temperature_c, w.water.salinity_psu, reference_depth_m=w.depth_m)
    cur = CurrentSpec(
        velocity=w.water.current_mps,
        variation=w.water.current_variability,
        seed=scn.world_seed + 1,
    )
    objects = []
    for i, o in enumerate(w.objects):
        from sim.world.objects import OBJECT_CLASSES

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
        VehicleSpec(
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


def mission_for(v: VehicleSpec, swath: float):
    """sim.guidance Mission from a vehicle's mission spec (swath for lawnmower spacing)."""
    from sim.guidance import hold, lawnmower, loop, straight_line

    m = v.mission
    kw = {"depth": m.depth_m, "altitude": m.altitude_m}
    heading = math.radians(m.heading_deg)
    if m.type == "lawnmower":
        return lawnmower(
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
    if m.type in ("loop",):
        return loop(np.array(m.waypoints), laps=m.loops, speed=m.speed_mps, **kw)
    if m.type == "waypoints":
        from sim.guidance import Mission

        return Mission(
            "waypoints", np.array(m.waypoints, float), m.speed_mps, m.depth_m, m.altitude_m
        )
    if m.type == "line":
        return straight_line(m.waypoints[0], m.waypoints[-1], speed=m.speed_mps, **kw)
    return hold(m.center, duration=1e9, **kw)


# ----------------------------------------------------------------------- runtime --------


@dataclass
class SonarRuntime:
    spec: SonarSpec
    kind: str  # "sss" | "fls" | "msis"
    sonar: object
    period: float
    rng: np.random.Generator
    next_t: float = 0.0
    processor: SidescanProcessor | None = None
    msis_angles: np.ndarray | None = None
    msis_k: int = 0
    msis_pings: list = field(default_factory=list)
    frames: int = 0
    sss_pings: list = field(default_factory=list)  # (pose_true, ground range) for the mosaic
    horizon: float = -math.inf
    polar: PolarFrontend | None = None  # FLS / MSIS front end (sim.runner.fls_msis)


@dataclass
class VehicleRuntime:
    spec: VehicleSpec
    handle: object
    autopilot: object
    nav: object
    lagged: LaggedSlam | None
    sonars: list[SonarRuntime]
    true_t: list = field(default_factory=list)
    true_pose: list = field(default_factory=list)  # [x, y, z, yaw]
    detections: list = field(default_factory=list)
    det_counts: dict = field(default_factory=lambda: defaultdict(int))
    fp_pixels: int = 0
    bg_pixels: int = 0
    imaged_ids: set = field(default_factory=set)
    speed: float = 0.0
    dr_t: list = field(default_factory=list)  # dead reckoning alone: the same odometry, no updates
    dr_pose: list = field(default_factory=list)
    altitude_nav: float = float("nan")


class _Timer:
    def __init__(self) -> None:
        self.s: dict[str, float] = defaultdict(float)

    def add(self, k: str, t0: float) -> float:
        t1 = time.perf_counter()
        self.s[k] += t1 - t0
        return t1


def _yaw(q) -> float:
    w, x, y, z = (float(a) for a in q)
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def _segmenter(method: str, preset: str, is_fls: bool = False):
    """Adapter: image -> (labels, regions) with slam.frontend.segmentation. ``"auto"`` is
    the front end's size rule for the actual image, for every sonar: the reference's
    ``fls`` preset (a = 40 px, N_max = 600) belongs to its 1920 x 932 frames and removes
    small objects of a 256 x 128 frame (sim.runner.fls_msis)."""
    from slam.frontend.segmentation.methods import segment

    del is_fls

    def run(img: np.ndarray):
        res = segment(img, method=method, params=preset)
        return res.labels, list(res.regions)

    return run


@dataclass
class RunResult:
    out_dir: Path
    metrics: dict
    complete: bool

    def summary(self) -> str:
        m = self.metrics
        lines = [f"run {'complete' if self.complete else 'INTERRUPTED'}: {self.out_dir}"]
        for name, v in m.get("vehicles", {}).items():
            lm, po, de = v.get("landmarks", {}), v.get("pose", {}), v.get("detections", {})
            lines.append(
                f"  {name}: ATE {_fmt(po.get('ate_m'))} m, NEES {_fmt(po.get('nees_mean'))}, "
                f"landmarks {lm.get('n_estimated', 0)} (RMSE {_fmt(lm.get('rmse_m'))} m), "
                f"detections {de.get('n_detections', 0)} (PPV {_fmt(de.get('ppv'))})"
            )
        t = m.get("timing", {})
        lines.append(
            f"  sim {m.get('sim_time_s', 0):.1f} s in {_fmt(t.get('wall_s'))} s (RTF {_fmt(t.get('real_time_factor'))})"
        )
        return "\n".join(lines)


def _fmt(x) -> str:
    return "n/a" if x is None else f"{x:.3g}"


class ScenarioRun:
    """Builds everything for a scenario and runs it; see module docstring."""

    def __init__(self, scenario: Scenario, rec=None) -> None:
        from sim.guidance.world_adapter import autopilot_for
        from sim.navigation import NavSuite
        from sim.world import build_world

        self.scn = scenario
        self.rec = rec
        self.timer = _Timer()
        t0 = time.perf_counter()
        self.world = build_world(world_spec_from_scenario(scenario))
        self.timer.add("build_world", t0)
        ss = np.random.SeedSequence(scenario.seed)
        vseeds = ss.spawn(len(scenario.vehicles))
        self.vehicles: list[VehicleRuntime] = []
        for vs, vseed in zip(scenario.vehicles, vseeds):
            s_nav, s_slam, *s_sonar = vseed.spawn(2 + len(vs.sonars))
            handle = self.world.vehicles[vs.name]
            sonars = [
                self._make_sonar(vs, sp, np.random.default_rng(sd))
                for sp, sd in zip(vs.sonars, s_sonar)
            ]
            swath = (
                2
                * max(
                    (getattr(s.sonar.config, "max_range", 30.0) for s in sonars if s.kind == "sss"),
                    default=30.0,
                )
                * 0.8
            )
            ap = autopilot_for(self.world, vs.name, mission_for(vs, swath), check=False)
            nav = NavSuite(vs.nav.suite_config(), np.random.default_rng(s_nav), t0=self.world.time)
            lag = None
            if vs.slam.estimator != "none" and any(
                s.kind in ("sss", "fls", "msis") for s in sonars
            ):
                lag = LaggedSlam(
                    self._make_estimator(vs, np.random.default_rng(s_slam)), t0=self.world.time
                )
            self.vehicles.append(VehicleRuntime(vs, handle, ap, nav, lag, sonars))
        self.t_sim = 0.0

    # -- construction helpers ---------------------------------------------------------
    def _make_sonar(self, vs: VehicleSpec, sp: SonarSpec, rng) -> SonarRuntime:
        from sim.sonar import ForwardLookingSonar, MSISSonar, SideScanSonar, preset

        cfg = preset(sp.preset, **dict(sp.overrides))
        w = self.world
        h = w.vehicles[vs.name]
        common = (w.model, w.data)
        mesh = w.static_mesh()
        kw = {
            "geom_object_id": w.geom_object_id,
            "geom_reflectivity": w.geom_reflectivity,
            "water": _SonarWater(w.water),
            "static_mesh": mesh,
        }
        fe = vs.frontend
        if sp.is_sidescan:
            son = SideScanSonar(
                cfg, *common, (h.site_ids["sss_port"], h.site_ids["sss_starboard"]), **kw
            )
            proc = None
            if fe.method != "none":
                proc = SidescanProcessor(
                    _segmenter(fe.method, fe.preset, False),
                    fe.window_pings,
                    fe.hop_pings,
                    merge_radius=vs.slam.association_gate_m,
                    along_track_beamwidth_deg=cfg.along_track_beamwidth_deg,
                    class_of=self._class_id,
                    prepare=make_sss_prepare(
                        cfg.acoustic.log_compression, cfg.acoustic.dynamic_range_db
                    ),
                )
            return SonarRuntime(sp, "sss", son, 1.0 / cfg.ping_rate_hz, rng, processor=proc)
        if sp.preset == "msis":
            son = MSISSonar(cfg, *common, h.site_ids["msis"], **kw)
            ang = son.head_angles()
            polar = None
            if fe.method != "none":
                polar = PolarFrontend(
                    "msis",
                    _segmenter(fe.method, fe.preset),
                    ranges=son.ranges,
                    angles=ang,
                    bin_width=cfg.bin_width,
                    angular_cell=math.radians(max(cfg.horizontal_beamwidth_deg, cfg.step_deg)),
                    log_compressed=cfg.acoustic.log_compression,
                    dynamic_range_db=cfg.acoustic.dynamic_range_db,
                    config=MSIS_FRONTEND,
                    mount_xy=tuple(w.model.site_pos[h.site_ids["msis"]][:2]),
                )
            return SonarRuntime(
                sp, "msis", son, 1.0 / cfg.ping_rate_hz, rng, msis_angles=ang, polar=polar
            )
        son = ForwardLookingSonar(cfg, *common, h.site_ids["fls"], **kw)
        polar = None
        if fe.method != "none":
            polar = PolarFrontend(
                "fls",
                _segmenter(fe.method, fe.preset),
                ranges=son.ranges,
                angles=son.bearings,
                bin_width=cfg.bin_width,
                angular_cell=math.radians(
                    max(cfg.beamwidth_deg, cfg.horizontal_fov_deg / cfg.n_beams)
                ),
                log_compressed=cfg.acoustic.log_compression,
                dynamic_range_db=cfg.acoustic.dynamic_range_db,
                config=FLS_FRONTEND,
                mount_xy=tuple(w.model.site_pos[h.site_ids["fls"]][:2]),
            )
        return SonarRuntime(sp, "fls", son, 1.0 / cfg.ping_rate_hz, rng, polar=polar)

    def _make_estimator(self, vs: VehicleSpec, rng):
        from slam.estimators import make_estimator

        x0 = np.array([vs.start_position[0], vs.start_position[1], math.radians(vs.start_yaw_deg)])
        P0 = np.diag([0.01, 0.01, math.radians(0.5) ** 2])
        params = dict(vs.slam.params)
        if vs.slam.estimator == "fastslam2":
            params.setdefault("rng", rng)
        return make_estimator(vs.slam.estimator, x0=x0, P0=P0, **params)

    def _class_id(self, oid: int) -> int:
        from sim.viz.rerun_log import class_id

        for o in self.world.objects:
            if o.id == oid:
                return class_id(o.class_name if o.class_name != "tree_branch" else "branch")
        return class_id("detection")

    # -- the loop ---------------------------------------------------------------------
    def run(self, duration: float, progress=None, stop_flag=None) -> bool:
        """Advance to ``duration`` s. Returns False if interrupted (KeyboardInterrupt)."""
        w = self.world
        dt_c = self.scn.control_dt
        phys = w.timestep
        n_ticks = math.floor(duration / dt_c + 1e-9)
        for v in self.vehicles:
            self._record_truth(v)
        try:
            for _ in range(n_ticks):
                t0 = time.perf_counter()
                for v in self.vehicles:
                    st = v.handle.state()
                    tau = v.autopilot.update(st, dt_c)
                    v.handle.apply_wrench_demand(tau)
                t0 = self.timer.add("guidance", t0)
                t_end = w.time + dt_c
                while True:
                    due = [
                        (s.next_t, i, j)
                        for i, v in enumerate(self.vehicles)
                        for j, s in enumerate(v.sonars)
                    ]
                    nxt = min(due) if due else None
                    if nxt is None or nxt[0] > t_end + 1e-9:
                        break
                    n = max(0, round((nxt[0] - w.time) / phys))
                    if n:
                        t0 = time.perf_counter()
                        w.step(n)
                        self.timer.add("physics", t0)
                    v = self.vehicles[nxt[1]]
                    s = v.sonars[nxt[2]]
                    self._nav_cut(v)
                    self._fire(v, s)
                    s.next_t += s.period
                n = max(0, round((t_end - w.time) / phys))
                if n:
                    t0 = time.perf_counter()
                    w.step(n)
                    self.timer.add("physics", t0)
                for v in self.vehicles:
                    self._nav_cut(v)
                    self._release(v)
                self.t_sim = w.time
                if self.rec is not None:
                    self._log_tick()
                if progress is not None:
                    progress(w.time)
                if stop_flag is not None and stop_flag():
                    raise KeyboardInterrupt
        except KeyboardInterrupt:
            self.t_sim = w.time
            return False
        # end of run: segment what is left of every waterfall and feed all remaining events
        for v in self.vehicles:
            for s in v.sonars:
                if s.processor is not None:
                    res = s.processor.flush()
                    if res is not None:
                        self._window_done(v, s, res)
                    s.horizon = math.inf
            self._release(v, final=True)
        return True

    def _record_truth(self, v: VehicleRuntime) -> None:
        st = v.handle.state()
        v.true_t.append(st.t)
        v.true_pose.append([st.position[0], st.position[1], st.position[2], _yaw(st.quat_wxyz)])

    def _nav_cut(self, v: VehicleRuntime) -> None:
        t0 = time.perf_counter()
        st = v.handle.state()
        r = v.nav.poll(st)
        if r.dvl:
            m = r.dvl[-1]
            if m.valid:
                v.speed = float(np.linalg.norm(np.asarray(m.velocity_body)[:2]))
            v.altitude_nav = float(m.altitude)
        if v.lagged is not None and st.t > (v.true_t[-1] if v.true_t else -1) + 1e-9:
            inc = v.nav.odometry(st.t)
            v.lagged.add_odometry(Odometry(inc.delta, inc.cov, inc.t))
            if not v.dr_pose:
                x0, _ = v.lagged.estimator.pose()
                v.dr_t.append(v.true_t[0])
                v.dr_pose.append(np.array(x0, float))
            v.dr_t.append(inc.t)
            v.dr_pose.append(apply_increment(v.dr_pose[-1], inc.delta))
        if not v.true_t or st.t > v.true_t[-1] + 1e-9:
            v.true_t.append(st.t)
            v.true_pose.append([st.position[0], st.position[1], st.position[2], _yaw(st.quat_wxyz)])
        self.timer.add("navigation", t0)

    def _fire(self, v: VehicleRuntime, s: SonarRuntime) -> None:
        t0 = time.perf_counter()
        d = self.world.data
        pose = np.array(v.true_pose[-1])[[0, 1, 3]]
        if s.kind == "sss":
            ping = s.sonar.ping(d, s.rng)
            t0 = self.timer.add("sonar", t0)
            S = ping.samples_per_side
            alt = ping.altitude if np.isfinite(ping.altitude) else v.altitude_nav
            if s.frames % 4 == 0:  # every 4th ping, every 4th sample, for the mosaic figure
                g = np.sqrt(
                    np.clip(
                        ping.slant_range[S:] ** 2 - (alt if np.isfinite(alt) else 0) ** 2, 0, None
                    )
                )
                port = ping.intensity[:S][::-1][::4]  # near -> far
                stbd = ping.intensity[S:][::4]
                s.sss_pings.append(
                    (
                        pose,
                        g[::4].astype(np.float32),
                        np.concatenate([port[::-1], stbd]).astype(np.float32),
                    )
                )
            s.frames += 1
            if s.processor is not None and np.isfinite(alt):
                rec = PingRecord(
                    ping.time,
                    ping.intensity,
                    ping.labels,
                    ping.slant_range[S:],
                    float(alt),
                    pose,
                    max(v.speed, 0.1),
                )
                t0 = time.perf_counter()
                res = s.processor.add(rec)
                t0 = self.timer.add("frontend", t0)
                if res is not None:
                    self._window_done(v, s, res)
        elif s.kind == "fls":
            frame = s.sonar.frame(d, s.rng)
            self.timer.add("sonar", t0)
            self._fls_frame(v, s, frame, pose)
        else:
            if s.msis_k == 0:  # a new scan starts: everything before it is final
                s.horizon = d.time - 1e-9
            ang = s.msis_angles[s.msis_k]
            ping = s.sonar.ping(d, s.rng, float(ang))
            self.timer.add("sonar", t0)
            s.msis_pings.append((ping, pose, self._nav_pose(v, pose)))
            s.msis_k += 1
            if s.msis_k >= len(s.msis_angles):
                self._msis_scan(v, s)
                s.msis_k = 0
                s.msis_pings = []

    def _window_done(self, v: VehicleRuntime, s: SonarRuntime, res) -> None:
        t0 = time.perf_counter()
        s.horizon = res.horizon_t
        v.fp_pixels += res.fp_pixels
        v.bg_pixels += res.bg_pixels
        v.imaged_ids |= res.imaged_ids
        v.detections.extend((s.spec.name, d) for d in res.detections)
        obs_by_t: dict[float, list] = defaultdict(list)
        for d in res.detections:
            obs_by_t[d.t].append(d.observation)
        if v.lagged is not None:
            timing = v.spec.slam.timing
            for t, obs in sorted(obs_by_t.items()):
                if timing == "lagged":
                    self._add_obs(v, t, obs)
                else:  # naive: as if seen now, from the current pose
                    self._add_obs(v, max(v.lagged.t_done, v.true_t[-1]), obs)
        self.timer.add("frontend", t0)
        if self.rec is not None and s.frames % self.scn.outputs.log_sonar_every == 0:
            from sim.viz import rerun_log as L

            L.set_time(self.rec, self.world.time)
            L.log_sonar_image(self.rec, v.spec.name, s.spec.name, res.image, res.overlay)
            if res.detections:
                L.log_detections(
                    self.rec,
                    v.spec.name,
                    s.spec.name,
                    np.array(
                        [
                            [*d.world_xy_true_pose, self._seabed_z(d.world_xy_true_pose)]
                            for d in res.detections
                        ]
                    ),
                    [f"obj {d.object_id}" if d.object_id else "?" for d in res.detections],
                )

    def _add_obs(self, v: VehicleRuntime, t: float, obs: list) -> None:
        """Queue observations at their time; one older than the released horizon (cannot
        happen with ping ownership, kept as a guard) is counted and dropped."""
        if t < v.lagged.t_done - 1e-9:
            v.det_counts["dropped_late"] += len(obs)
            return
        v.lagged.add_observations(t, obs)

    def _seabed_z(self, xy) -> float:
        return float(self.world.seabed_height(np.asarray(xy, float).reshape(1, 2))[0])

    @staticmethod
    def _nav_pose(v: VehicleRuntime, pose_true: np.ndarray) -> np.ndarray:
        """The navigation (dead-reckoning) pose at the current time: what the FLS / MSIS
        persistence filter places candidates with. Without SLAM there is no odometry
        chain and nothing consumes observations; the true pose then serves detection
        scoring only."""
        return np.array(v.dr_pose[-1], float) if v.dr_pose else np.asarray(pose_true, float)

    def _fls_frame(self, v: VehicleRuntime, s: SonarRuntime, frame, pose) -> None:
        """One FLS frame through sim.runner.fls_msis; confirmed detections are scored,
        keyframed ones become observations at the frame's time."""
        t0 = time.perf_counter()
        s.frames += 1
        if s.polar is None:
            return
        res = s.polar.process(
            frame.image,
            altitude=v.altitude_nav if np.isfinite(v.altitude_nav) else None,
            poses_nav=self._nav_pose(v, pose),
            times=frame.time,
        )
        self._polar_done(v, s, res, frame.labels, np.broadcast_to(pose, (1, 3)), "fls")
        self.timer.add("frontend", t0)
        if self.rec is not None and s.frames % max(1, self.scn.outputs.log_sonar_every * 5) == 0:
            from sim.viz import rerun_log as L

            L.set_time(self.rec, self.world.time)
            overlay = np.where(res.groups > 0, np.where(frame.labels > 0, 2, 255), 0).astype(
                np.uint16
            )
            L.log_sonar_image(self.rec, v.spec.name, s.spec.name, frame.image, overlay)

    def _polar_done(self, v, s, res, truth_labels, poses_true, kind: str) -> None:
        """Score a polar front-end result against the simulator's labels (confirmed
        detections; a detection is a true positive when >= 10 % of its cells carry an
        object id), record them and queue the keyframed observations."""
        from slam.frontend.sidescan_windows import Detection

        g = res.groups
        lab = np.asarray(truth_labels)
        v.imaged_ids |= set(np.unique(lab[lab > 0]).tolist())
        bg = lab == 0
        v.bg_pixels += int(np.count_nonzero(bg))
        v.det_counts[f"{kind}_regions"] += res.n_regions
        v.det_counts[f"{kind}_candidates"] += res.n_candidates
        conf = [d for d in res.detections if d.confirmed]
        v.det_counts[f"{kind}_confirmed"] += len(conf)
        if not conf:
            return
        ng = int(g.max())
        top = int(max(lab.max(), 0)) + 1
        obj = lab > 0
        pair = np.bincount(g[obj] * top + lab[obj], minlength=(ng + 1) * top).reshape(ng + 1, top)
        n_cells = np.bincount(g.ravel(), minlength=ng + 1)
        kept = np.isin(g, [d.group for d in conf])
        v.fp_pixels += int(np.count_nonzero(kept & bg))
        obs = []
        for d in conf:
            n_obj = int(pair[d.group].sum())
            oid = int(pair[d.group].argmax()) if n_obj else 0
            pt = poses_true[min(d.row, len(poses_true) - 1)] if kind == "msis" else poses_true[0]
            o = d.observation
            a = pt[2] + o.z[1]
            wxy = pt[:2] + o.z[0] * np.array([math.cos(a), math.sin(a)])
            v.detections.append(
                (
                    s.spec.name,
                    Detection(
                        o.t,
                        d.row,
                        kind,
                        float(o.z[0]),
                        float(o.z[0]),
                        d.area_px,
                        o,
                        oid,
                        n_obj >= 0.1 * n_cells[d.group],
                        wxy,
                    ),
                )
            )
            if d.emitted:
                obs.append(o)
        v.det_counts[f"{kind}_observations"] += len(obs)
        if v.lagged is not None and obs:
            by_t: dict[float, list] = defaultdict(list)
            for o in obs:
                by_t[o.t].append(o)
            for t, ob in sorted(by_t.items()):
                self._add_obs(v, t, ob)

    def _msis_scan(self, v: VehicleRuntime, s: SonarRuntime) -> None:
        """A completed MSIS scan: one polar image (head angles, bins) through
        sim.runner.fls_msis; each detection is tied to the ping of its centroid row."""
        t0 = time.perf_counter()
        pings = [p[0] for p in s.msis_pings]
        img = np.stack([p.intensity for p in pings])
        lab = np.stack([p.labels for p in pings])
        if s.polar is not None:
            res = s.polar.process(
                img,
                altitude=v.altitude_nav if np.isfinite(v.altitude_nav) else None,
                poses_nav=np.array([p[2] for p in s.msis_pings]),
                times=np.array([p.time for p in pings]),
            )
            self._polar_done(v, s, res, lab, np.array([p[1] for p in s.msis_pings]), "msis")
        s.horizon = self.world.time
        self.timer.add("frontend", t0)
        if self.rec is not None:
            from sim.viz import rerun_log as L

            L.set_time(self.rec, self.world.time)
            L.log_sonar_image(self.rec, v.spec.name, s.spec.name, img)

    def _release(self, v: VehicleRuntime, final: bool = False) -> None:
        if v.lagged is None:
            return
        t0 = time.perf_counter()
        horizon = min(
            [s.horizon if s.kind != "fls" else math.inf for s in v.sonars] + [self.world.time]
        )
        if final or horizon > v.lagged.t_done:
            v.lagged.release(min(horizon, self.world.time) if not final else self.world.time)
        self.timer.add("slam", t0)

    # -- recording ---------------------------------------------------------------------
    def log_static(self) -> None:
        from sim.viz import rerun_log as L

        rec = self.rec
        L.log_annotations(rec)
        vtx, f, _ = self.world.static_mesh()
        L.log_seabed(rec, vtx, f)
        objs = self.world.objects
        if objs:
            L.log_objects(
                rec,
                [o.id for o in objs],
                [o.class_name for o in objs],
                np.array(
                    [np.asarray(o.position) + np.array([0.0, 0.0, o.size[2] / 2]) for o in objs]
                ),
                np.array([o.size for o in objs]),
            )
        for v in self.vehicles:
            mesh = vehicle_body_mesh(self.world.model, self.world.data, v.handle.body_id)
            if mesh is None:
                L.log_vehicle_mesh(rec, v.spec.name, *_box_mesh(*v.handle.model.envelope))
            else:
                L.log_vehicle_mesh(rec, v.spec.name, mesh[0], mesh[1], vertex_colors=mesh[2])

    def _log_tick(self) -> None:
        from sim.viz import rerun_log as L

        rec = self.rec
        k = round(self.world.time / self.scn.control_dt)
        if k % max(1, round(0.5 / self.scn.control_dt)) != 0:
            return
        L.set_time(rec, self.world.time)
        for v in self.vehicles:
            st = v.handle.state()
            L.log_vehicle_pose(rec, v.spec.name, st.position, st.quat_wxyz)
            if k % max(1, round(5.0 / self.scn.control_dt)) == 0:
                tp = np.array(v.true_pose)
                L.log_trajectory(rec, v.spec.name, "true", tp[::5, :3])
                if v.lagged is not None and v.lagged.history:
                    h = np.array([r.x for r in v.lagged.history])
                    z = np.interp([r.t for r in v.lagged.history], v.true_t, tp[:, 2])
                    L.log_trajectory(
                        rec, v.spec.name, "estimated", np.column_stack([h[::5, :2], z[::5]])
                    )
                    means, covs = v.lagged.estimator.landmarks()
                    if len(means):
                        L.log_landmarks(rec, v.spec.name, means, covs, self._seabed_z_many(means))
                    x, P = v.lagged.estimator.pose()
                    L.log_scalars(
                        rec,
                        v.spec.name,
                        {
                            "slam/sigma_x_m": math.sqrt(max(P[0, 0], 0.0)),
                            "slam/sigma_yaw_deg": math.degrees(math.sqrt(max(P[2, 2], 0.0))),
                            "slam/n_landmarks": float(len(means)),
                            "slam/lag_s": self.world.time - v.lagged.t_done,
                            "slam/position_error_m": float(
                                np.hypot(
                                    *(
                                        np.interp(v.lagged.t_done, v.true_t, tp[:, 0]) - x[0],
                                        np.interp(v.lagged.t_done, v.true_t, tp[:, 1]) - x[1],
                                    )
                                )
                            ),
                        },
                    )
                L.log_scalars(rec, v.spec.name, {"detections": float(len(v.detections))})

    def _seabed_z_many(self, xy) -> np.ndarray:
        return self.world.seabed_height(np.asarray(xy, float).reshape(-1, 2)) + 0.5

    # -- results -----------------------------------------------------------------------
    def metrics(self) -> dict:
        objs = self.world.objects
        truth_xy = np.array([np.asarray(o.position)[:2] for o in objs]).reshape(-1, 2)
        out: dict = {}
        for v in self.vehicles:
            tt = np.array(v.true_t)
            tp = np.array(v.true_pose)
            d: dict = {
                "kind": v.spec.kind,
                "distance_travelled_m": float(np.sum(np.hypot(*np.diff(tp[:, :2], axis=0).T))),
            }
            dets = [x for _, x in v.detections]
            tp_n = sum(1 for x in dets if x.true_positive)
            d["detections"] = detection_metrics(
                tp_n,
                len(dets) - tp_n,
                v.fp_pixels,
                v.bg_pixels,
                [x.object_id for x in dets if x.true_positive],
                sorted(v.imaged_ids),
            )
            if objs and dets:
                wxy = np.array([x.world_xy_true_pose for x in dets])
                near = {}
                for o in objs:
                    dist = np.linalg.norm(wxy - np.asarray(o.position)[:2], axis=1)
                    near[f"{o.class_name}_{o.id}"] = float(dist.min())
                d["detections"]["nearest_detection_m"] = near
            if v.det_counts:
                d["detections"]["pipeline_counts"] = dict(sorted(v.det_counts.items()))
            if v.lagged is not None:
                hist = v.lagged.history
                if hist:
                    ht = np.array([r.t for r in hist])
                    est = np.array([r.x for r in hist])
                    cov = np.array([r.P for r in hist])
                    truth = np.column_stack(
                        [
                            np.interp(ht, tt, tp[:, 0]),
                            np.interp(ht, tt, tp[:, 1]),
                            _interp_angle(ht, tt, tp[:, 3]),
                        ]
                    )
                    d["pose"] = pose_metrics(ht, est, cov, truth)
                    if v.dr_pose:  # the same odometry without any sonar update, same times
                        dr = np.array(v.dr_pose)
                        drt = np.array(v.dr_t)
                        e = (
                            np.column_stack(
                                [np.interp(ht, drt, dr[:, 0]), np.interp(ht, drt, dr[:, 1])]
                            )
                            - truth[:, :2]
                        )
                        d["pose"]["dead_reckoning_ate_m"] = float(
                            np.sqrt(np.mean(np.sum(e**2, axis=1)))
                        )
                means, covs = v.lagged.estimator.landmarks()
                seen = [i for i, o in enumerate(objs) if o.id in v.imaged_ids]
                d["landmarks"] = landmark_metrics(
                    means, covs, truth_xy[seen] if seen else np.zeros((0, 2))
                )
                d["landmarks"]["n_objects_imaged"] = len(seen)
                d["slam"] = {
                    "estimator": v.spec.slam.estimator,
                    "timing": v.spec.slam.timing,
                    "n_predicts": v.lagged.n_predicts,
                    "n_updates": v.lagged.n_updates,
                }
            out[v.spec.name] = d
        return out


def _interp_angle(t, tt, a) -> np.ndarray:
    u = np.unwrap(a)
    r = np.interp(t, tt, u)
    return (r + np.pi) % (2 * np.pi) - np.pi


def vehicle_body_mesh(model, data, body_id: int):
    """Triangle mesh of a vehicle's geoms in its root body frame (for display):
    (vertices (V, 3) m, faces (F, 3), vertex colours (V, 3) uint8). Primitive geoms
    (sphere, capsule, ellipsoid, cylinder, box) via trimesh, mesh geoms from the model;
    None if the body has no displayable geom."""
    import mujoco
    import trimesh

    R0 = data.xmat[body_id].reshape(3, 3)
    p0 = data.xpos[body_id]
    vs, fs, cs = [], [], []
    off = 0
    T = mujoco.mjtGeom
    for g in range(model.ngeom):
        if model.body_rootid[model.geom_bodyid[g]] != body_id:
            continue
        t, sz = int(model.geom_type[g]), model.geom_size[g]
        if t == T.mjGEOM_SPHERE:
            m = trimesh.creation.icosphere(subdivisions=1, radius=sz[0])
        elif t == T.mjGEOM_CAPSULE:
            m = trimesh.creation.capsule(height=2 * sz[1], radius=sz[0], count=[12, 6])
        elif t == T.mjGEOM_ELLIPSOID:
            m = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
            m.vertices = m.vertices * sz[:3]
        elif t == T.mjGEOM_CYLINDER:
            m = trimesh.creation.cylinder(radius=sz[0], height=2 * sz[1], sections=16)
        elif t == T.mjGEOM_BOX:
            m = trimesh.creation.box(extents=2 * sz[:3])
        elif t == T.mjGEOM_MESH:
            mid = model.geom_dataid[g]
            va, vn = model.mesh_vertadr[mid], model.mesh_vertnum[mid]
            fa, fn = model.mesh_faceadr[mid], model.mesh_facenum[mid]
            m = trimesh.Trimesh(
                model.mesh_vert[va : va + vn].copy(),
                model.mesh_face[fa : fa + fn].copy(),
                process=False,
            )
        else:
            continue
        Rg = data.geom_xmat[g].reshape(3, 3)
        world = np.asarray(m.vertices) @ Rg.T + data.geom_xpos[g]
        vs.append((world - p0) @ R0)
        fs.append(np.asarray(m.faces) + off)
        cs.append(np.tile((model.geom_rgba[g, :3] * 255).astype(np.uint8), (len(m.vertices), 1)))
        off += len(m.vertices)
    if not vs:
        return None
    return np.concatenate(vs), np.concatenate(fs), np.concatenate(cs)


def _box_mesh(L: float, W: float, H: float) -> tuple[np.ndarray, np.ndarray]:
    v = np.array(
        [[x, y, z] for x in (-L / 2, L / 2) for y in (-W / 2, W / 2) for z in (-H / 2, H / 2)]
    )
    f = np.array(
        [
            [0, 1, 3],
            [0, 3, 2],
            [4, 6, 7],
            [4, 7, 5],
            [0, 4, 5],
            [0, 5, 1],
            [2, 3, 7],
            [2, 7, 6],
            [0, 2, 6],
            [0, 6, 4],
            [1, 5, 7],
            [1, 7, 3],
        ]
    )
    return v, f


class _SonarWater:
    """sim.world.Water seen through the sonar's WaterLike protocol (``depth`` of the datum)."""

    def __init__(self, water) -> None:
        self.temperature_c = water.temperature_c
        self.salinity_psu = water.salinity_psu
        self.sound_speed = water.sound_speed
        self.depth = float(water.surface_z)  # datum z = 0 lies surface_z below the surface


# ----------------------------------------------------------------------- entry point ----


def _progress_enabled(progress: bool | None) -> bool:
    if progress is not None:
        return progress
    return sys.stderr.isatty() and os.environ.get("CI", "").lower() not in ("1", "true", "yes")


def run_scenario(
    scenario: Scenario,
    out_dir: str | Path,
    *,
    overwrite: bool = False,
    progress: bool | None = None,
    stop_flag=None,
) -> RunResult:
    """Run a validated scenario headless and write its outputs to ``out_dir``.

    progress: tqdm bar with sim time, real-time factor and ETA (default: on a TTY unless
    CI=true). stop_flag: optional callable polled every tick; True stops the run as
    Ctrl-C does (used by tests). Returns the metrics and whether the run completed.
    """
    from sim.viz import rerun_log as L

    out = RunDirectory(out_dir, overwrite=overwrite)
    wall0 = time.perf_counter()
    rec = None
    if scenario.outputs.recording:
        bp = L.default_blueprint({v.name: [s.name for s in v.sonars] for v in scenario.vehicles})
        rec = L.open_recording(
            out.path("recording.rrd"),
            application_id="undersea",
            recording_id=f"{scenario.name}-seed{scenario.seed}",
            blueprint=bp,
        )
    run = ScenarioRun(scenario, rec)
    if rec is not None:
        run.log_static()
    bar = None
    cb = None
    if _progress_enabled(progress):
        from tqdm import tqdm

        bar = tqdm(
            total=round(scenario.duration_s, 1),
            unit="sim s",
            desc=scenario.name,
            dynamic_ncols=True,
            bar_format="{l_bar}{bar}| {n:.1f}/{total:.1f} sim s [{elapsed}<{remaining} ETA{postfix}]",
        )
        last = [0.0]

        def cb(t: float) -> None:
            if t - last[0] >= 1.0 or t >= scenario.duration_s - 1e-6:
                bar.update(round(t - last[0], 1))
                last[0] = round(t, 1)
                el = time.perf_counter() - wall0
                bar.set_postfix_str(f"RTF {t / max(el, 1e-9):.2f}")

    complete = False
    error: BaseException | None = None
    try:
        complete = run.run(scenario.duration_s, progress=cb, stop_flag=stop_flag)
    except BaseException as exc:  # write what we have, marked incomplete, then re-raise
        error = exc
    finally:
        if bar is not None:
            bar.close()
    wall = time.perf_counter() - wall0
    metrics = {
        "scenario": scenario.name,
        "seed": scenario.seed,
        "complete": complete,
        "duration_s": scenario.duration_s,
        "sim_time_s": round(run.t_sim, 6),
        "vehicles": run.metrics(),
        "objects": [
            {
                "id": o.id,
                "class": o.class_name,
                "position": np.round(np.asarray(o.position), 4).tolist(),
            }
            for o in run.world.objects
        ],
        "timing": {
            "note": "wall-clock seconds; the only part of this file that varies between identical runs",
            "wall_s": wall,
            "real_time_factor": run.t_sim / wall if wall > 0 else None,
            "stages_s": dict(run.timer.s),
        },
    }
    if error is not None:
        metrics["error"] = f"{type(error).__name__}: {error}"
    if not complete:
        metrics["interrupted_at_s"] = round(run.t_sim, 6)
    if rec is not None:
        L.close_recording(rec)
    if scenario.outputs.figures:
        try:
            _figures(run, out)
        except Exception as exc:  # figures must not lose the run's data
            metrics["figures_error"] = f"{type(exc).__name__}: {exc}"
    out.write_json("metrics.json", metrics)
    final = out.finalize()
    if error is not None and not isinstance(error, KeyboardInterrupt):
        raise error
    return RunResult(final, metrics, complete)


def _figures(run: ScenarioRun, out: RunDirectory) -> None:
    from sim.runner.figures import (
        VehiclePlotData,
        mosaic_grid,
        plot_sss_mosaic,
        plot_trajectory_map,
        sss_sample_world_xy,
    )

    objs = [(o.class_name, np.asarray(o.position), np.asarray(o.size)) for o in run.world.objects]
    vd = []
    mos = {}
    dets_by = {}
    sx, sy = run.scn.world.size_m
    ext = (-sx / 2, sx / 2, -sy / 2, sy / 2)
    for v in run.vehicles:
        tp = np.array(v.true_pose)
        est = (
            np.array([r.x[:2] for r in v.lagged.history])
            if v.lagged and v.lagged.history
            else np.zeros((0, 2))
        )
        means, covs = (
            v.lagged.estimator.landmarks() if v.lagged else (np.zeros((0, 2)), np.zeros((0, 2, 2)))
        )
        dxy = np.array([d.world_xy_true_pose for _, d in v.detections]).reshape(-1, 2)
        vd.append(
            VehiclePlotData(
                v.spec.name,
                tp[:, :2],
                est,
                np.asarray(means).reshape(-1, 2),
                np.asarray(covs).reshape(-1, 2, 2),
                dxy,
            )
        )
        for s in v.sonars:
            if s.kind == "sss" and s.sss_pings:
                poses = np.array([p[0] for p in s.sss_pings])
                g = np.array([p[1] for p in s.sss_pings])
                inten = np.array([p[2] for p in s.sss_pings])
                xy = sss_sample_world_xy(poses, g)
                key = f"{v.spec.name}/{s.spec.name}"
                mos[key] = (mosaic_grid(xy.reshape(-1, 2), inten.reshape(-1), ext, 0.5), ext)
                dets_by[key] = np.array(
                    [d.world_xy_true_pose for sn, d in v.detections if sn == s.spec.name]
                ).reshape(-1, 2)
    plot_trajectory_map(out.path("trajectory_map.png"), vd, objs, title=run.scn.name, extent=ext)
    if mos:
        plot_sss_mosaic(out.path("sss_mosaic.png"), mos, dets_by, objs, title=run.scn.name)

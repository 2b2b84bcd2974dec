"""The scenario loop: physics, navigation sensors, sonars at their ping rates, each sonar
frame into the vehicle's sonar-to-SLAM pipeline (slam.pipeline.SonarSlam).

One control tick (``scenario.control_dt``): every vehicle's autopilot (sim.guidance)
turns its own navigation state (``NavSuite.navigation_state``: dead-reckoned x, y, yaw
and the depth sensor; truth stays in metrics) into a body wrench demand; SLAM runs
beside it. Physics then
advances in whole physics steps to each sonar ping due inside the tick; at each ping the
vehicle's nav suite is polled and its odometry cut at the ping time, so every sonar
observation has an odometry node at exactly its time. Each ping becomes a
:class:`slam.pipeline.SonarFrame` (with the simulator's labels and true pose as optional
truth); the pipeline segments side-scan windows, FLS frames and MSIS scans and releases
SLAM in time order. What happened goes to the observers (sim.runner.log) at the end of
each frame and tick; scores accumulate in each vehicle's tally (slam.pipeline.scoring).
"""

from __future__ import annotations

import math
import time
from collections import defaultdict

import numpy as np

from sim.guidance.missions import hold
from sim.guidance.world_adapter import autopilot_for
from sim.navigation import NavSuite
from sim.runner.build import (
    SonarRuntime,
    VehicleRuntime,
    make_pipeline,
    make_sonar,
    mission_for,
    nav_suite_config,
    world_spec_from_scenario,
)
from sim.scenario.schema import Scenario
from sim.world import build_world
from slam.pipeline import FrameOutput, FrameTruth, SonarFrame
from slam.types import Odometry


class StageTimer:
    """Wall-clock seconds per stage (metrics.json's "timing" section)."""

    def __init__(self) -> None:
        self.s: dict[str, float] = defaultdict(float)

    def add(self, k: str, t0: float) -> float:
        t1 = time.perf_counter()
        self.s[k] += t1 - t0
        return t1


def yaw_of(q) -> float:
    """Yaw (rad, ccw from x) of a unit wxyz quaternion."""
    w, x, y, z = (float(a) for a in q)
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def step_to(world, t: float, timer: StageTimer | None = None) -> None:
    """Advance physics in whole steps to the step nearest ``t`` s (not backwards)."""
    n = max(0, round((t - world.time) / world.timestep))
    if n:
        t0 = time.perf_counter()
        world.step(n)
        if timer is not None:
            timer.add("physics", t0)


def advance_tick(world, pilots, tracks, dt_c: float, on_ping, timer: StageTimer | None = None):
    """One control tick of the scenario clock (module docstring), shared by the runner and
    the dataset exporter: each (handle, autopilot, steer) of ``pilots`` sets its wrench
    demand from ``steer(true state)`` — the vehicle's own navigation estimate in a run
    (``NavSuite.navigation_state``), the true state where ``steer`` is None; physics
    advances to each ping due inside the tick (``tracks``:
    objects with ``next_t`` and ``period`` s; ties in list order), ``on_ping(k)`` fires
    track k there; then physics runs to the end of the tick."""
    t0 = time.perf_counter()
    for handle, autopilot, steer in pilots:
        st = handle.state()
        handle.apply_wrench_demand(autopilot.update(st if steer is None else steer(st), dt_c))
    if timer is not None:
        timer.add("guidance", t0)
    t_end = world.time + dt_c
    while tracks:
        k = min(range(len(tracks)), key=lambda i: (tracks[i].next_t, i))
        if tracks[k].next_t > t_end + 1e-9:
            break
        step_to(world, tracks[k].next_t, timer)
        on_ping(k)
        tracks[k].next_t += tracks[k].period
    step_to(world, t_end, timer)


class RunObserver:
    """What a run tells its observers (all no-ops here; sim.runner.log.RerunObserver
    records them). ``on_frame`` gets every pipeline output that processed something."""

    def on_start(self, run: ScenarioRun) -> None: ...

    def on_frame(
        self, run: ScenarioRun, v: VehicleRuntime, s: SonarRuntime, out: FrameOutput
    ) -> None: ...

    def on_tick(self, run: ScenarioRun) -> None: ...


class ScenarioRun:
    """Builds everything for a scenario (sim.runner.build) and runs it; see the module
    docstring. observers: :class:`RunObserver` instances told what happened;
    linear_sonars: build the sonars without log compression (dataset export)."""

    def __init__(self, scenario: Scenario, observers=(), *, linear_sonars: bool = False) -> None:
        self.scn = scenario
        self.observers = list(observers)
        self.timer = StageTimer()
        t0 = time.perf_counter()
        self.world = build_world(world_spec_from_scenario(scenario))
        self.timer.add("build_world", t0)
        ss = np.random.SeedSequence(scenario.seed)
        vseeds = ss.spawn(len(scenario.vehicles))
        self.vehicles: list[VehicleRuntime] = []
        for vs, vseed in zip(scenario.vehicles, vseeds):
            s_nav, s_slam, *s_sonar = vseed.spawn(2 + len(vs.sonars))
            sonars = [
                make_sonar(self.world, vs.name, sp, np.random.default_rng(sd), linear=linear_sonars)
                for sp, sd in zip(vs.sonars, s_sonar)
            ]
            swath = 2 * max(
                (s.sonar.config.max_range for s in sonars if s.kind == "sss"), default=30.0
            )
            ap = autopilot_for(self.world, vs.name, mission_for(vs, swath * 0.8), check=False)
            pose0 = np.array([*vs.start_position[:2], math.radians(vs.start_yaw_deg)])
            nav = NavSuite(
                nav_suite_config(vs),
                np.random.default_rng(s_nav),
                t0=self.world.time,
                initial_pose=pose0,
            )
            pipe = make_pipeline(self.world, vs, sonars, np.random.default_rng(s_slam))
            handle = self.world.vehicles[vs.name]
            self.vehicles.append(VehicleRuntime(vs, handle, ap, nav, pipe, sonars))
        self.t_sim = 0.0

    # -- the loop ---------------------------------------------------------------------
    def run(self, duration: float, progress=None, stop_flag=None) -> bool:
        """Advance to ``duration`` s. Returns False if interrupted (KeyboardInterrupt)."""
        w = self.world
        dt_c = self.scn.control_dt
        n_ticks = math.floor(duration / dt_c + 1e-9)
        for v in self.vehicles:
            self._record_truth(v)
        try:
            for _ in range(n_ticks):
                self._tick(dt_c)
                self.t_sim = w.time
                for o in self.observers:
                    o.on_tick(self)
                if progress is not None:
                    progress(w.time)
                if stop_flag is not None and stop_flag():
                    raise KeyboardInterrupt
        except KeyboardInterrupt:
            self.t_sim = w.time
            return False
        # end of run: segment what is left of every waterfall and feed all remaining events
        for v in self.vehicles:
            for out in v.slam.flush():
                self._frame_done(v, self._sonar(v, out.sonar), out)
            t0 = time.perf_counter()
            v.slam.release(w.time, final=True)
            self.timer.add("slam", t0)
        return True

    def _tick(self, dt_c: float) -> None:
        """One control tick: guidance, physics to each due ping, pings, release."""
        tracks = [(v, s) for v in self.vehicles for s in v.sonars]
        for v in self.vehicles:
            self._surface_if_due(v)

        def on_ping(k: int) -> None:
            v, s = tracks[k]
            self._nav_cut(v)
            self._fire(v, s)

        advance_tick(
            self.world,
            [(v.handle, v.autopilot, v.nav.navigation_state) for v in self.vehicles],
            [s for _, s in tracks],
            dt_c,
            on_ping,
            self.timer,
        )
        for v in self.vehicles:
            self._nav_cut(v)
            t0 = time.perf_counter()
            v.slam.release(self.world.time)
            self.timer.add("slam", t0)

    def _surface_if_due(self, v: VehicleRuntime) -> None:
        """At the mission's ``surface_at_s``: leave the mission and hold at the surface
        above the position the vehicle's own navigation gives (GPS fixes from there)."""
        t_s = v.spec.mission.surface_at_s
        if t_s is None or v.surfacing or self.world.time < t_s - 1e-9:
            return
        xy = v.nav.navigation_state(v.handle.state()).position[:2]
        mission = hold(np.asarray(xy, float), duration=1e9, depth=0.0)
        v.autopilot = autopilot_for(self.world, v.spec.name, mission, check=False)
        v.surfacing = True

    def _record_truth(self, v: VehicleRuntime, st=None) -> None:
        """Append the true pose now (``st``: the vehicle's state already read now)."""
        st = v.handle.state() if st is None else st
        v.true_t.append(st.t)
        v.true_pose.append([st.position[0], st.position[1], st.position[2], yaw_of(st.quat_wxyz)])

    def _nav_cut(self, v: VehicleRuntime) -> None:
        """Poll the nav suite; cut the odometry at the current time into the pipeline."""
        t0 = time.perf_counter()
        st = v.handle.state()
        r = v.nav.poll(st)
        v.gps_fixes.extend((m.t, m.position_xy) for m in r.gps if m.valid)
        if r.dvl:
            m = r.dvl[-1]
            if m.valid:
                v.speed = float(np.linalg.norm(np.asarray(m.velocity_body)[:2]))
            v.altitude_nav = float(m.altitude)
        if st.t > v.true_t[-1] + 1e-9:
            inc = v.nav.odometry(st.t)
            v.slam.add_odometry(Odometry(inc.delta, inc.cov, inc.t))
            self._record_truth(v, st)
        self.timer.add("navigation", t0)

    def _fire(self, v: VehicleRuntime, s: SonarRuntime) -> None:
        """One ping of sonar ``s`` -> a SonarFrame -> the pipeline."""
        t0 = time.perf_counter()
        d = self.world.data
        pose = np.array(v.true_pose[-1])[[0, 1, 3]]
        alt = v.altitude_nav
        if s.kind == "sss":
            ping = s.sonar.ping(d, s.rng)
            image, labels, t = ping.intensity, ping.labels, ping.time
            if np.isfinite(ping.altitude):
                alt = ping.altitude
            self._keep_for_mosaic(s, ping, alt, pose)
        elif s.kind == "fls":
            fr = s.sonar.frame(d, s.rng)
            image, labels, t = fr.image, fr.labels, fr.time
        else:
            ping = s.sonar.ping(d, s.rng, float(s.geometry.bearings[s.msis_k]))
            image, labels, t = ping.intensity, ping.labels, ping.time
            s.msis_k = (s.msis_k + 1) % len(s.geometry.bearings)
        t0 = self.timer.add("sonar", t0)
        s.frames += 1
        frame = SonarFrame(
            s.spec.name,
            image,
            s.geometry,
            float(t),
            altitude=float(alt),
            speed=v.speed,
            truth=FrameTruth(labels, pose),
        )
        out = v.slam.add_frame(frame)
        self.timer.add("frontend", t0)
        if out.window is not None or out.polar is not None or out.frames:
            self._frame_done(v, s, out)

    @staticmethod
    def _keep_for_mosaic(s: SonarRuntime, ping, alt: float, pose: np.ndarray) -> None:
        """Every 4th ping, every 4th sample, for the side-scan mosaic figure."""
        if s.frames % 4 != 0:
            return
        S = ping.samples_per_side
        h = alt if np.isfinite(alt) else 0
        g = np.sqrt(np.clip(ping.slant_range[S:] ** 2 - h**2, 0, None))
        port = ping.intensity[:S][::-1][::4]  # near -> far
        stbd = ping.intensity[S:][::4]
        s.sss_pings.append(
            (pose, g[::4].astype(np.float32), np.concatenate([port[::-1], stbd]).astype(np.float32))
        )

    def _frame_done(self, v: VehicleRuntime, s: SonarRuntime, out: FrameOutput) -> None:
        if out.window is not None or out.polar is not None:
            v.tally.add(out)
        for o in self.observers:
            o.on_frame(self, v, s, out)

    @staticmethod
    def _sonar(v: VehicleRuntime, name: str) -> SonarRuntime:
        return next(s for s in v.sonars if s.spec.name == name)

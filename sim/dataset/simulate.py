"""One shard's simulation: physics + guidance + the selected sonars, nothing else.

The world, the vehicles' autopilots and the sonars are built by the scenario runner
(:class:`sim.runner.schedule.ScenarioRun`, with SLAM and front end switched off), so a
dataset sees exactly the scenario ``undersea run`` simulates, and the clock is the
runner's (:func:`sim.runner.schedule.advance_tick`: every control tick each autopilot
turns the true state into a wrench demand, then physics advances in whole steps to each
sonar ping due inside the tick). Navigation and SLAM are not run.

Intensities are taken *linear* (µPa² after TVG): the sonars are built without log
compression (``ScenarioRun(linear_sonars=True)``), and the display image is made
afterwards with the same :func:`sim.sonar.acoustics.compress_log` and display floor the
simulator would have used.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field, replace

import numpy as np

from sim.runner.schedule import ScenarioRun, advance_tick
from sim.scenario.schema import OutputSpec, Scenario, parse_scenario
from sim.sonar import preset


@dataclass(frozen=True)
class SonarFrame:
    """One exported acquisition.

    kind       : "sss" (waterfall tile) or "fls".
    linear     : (H, W) float32 linear intensity, µPa² after TVG. SSS: (P pings, 2S samples),
                 row i = i-th ping in time order, columns port far→near then starboard
                 near→far. FLS: (bins, beams), row 0 nearest bin, column 0 = port edge.
    labels     : (H, W) int32 per-sample ground truth: k >= 1 object id, 0 seabed,
                 -1 no return, -2 another geom (a vehicle).
    config     : the sonar's config as the scenario set it (log compression as displayed).
    time       : s, time of the frame (SSS: its centre ping).
    pose       : true vehicle state at ``time`` (see :func:`pose_dict`).
    geometry   : JSON-able sonar geometry (ranges, bearings, per-ping poses, sensor pose).
    fls        : for FLS, the simulator's FLSFrame with the linear image (for the fan).
    """

    index: int
    kind: str
    vehicle: str
    vehicle_kind: str
    sonar: str
    preset: str
    config: object
    linear: np.ndarray
    labels: np.ndarray
    time: float
    pose: dict
    geometry: dict
    fls: object | None = None


def _r(a, nd: int = 6):
    """Rounded list (JSON-stable, compact)."""
    return np.round(np.asarray(a, dtype=float), nd).tolist()


def pose_dict(state) -> dict:
    """True vehicle state as JSON: position m (world x east, y north, z up), quaternion
    body→world (w, x, y, z), roll/pitch/yaw rad (yaw ccw from east), body velocity m/s,
    altitude m above the seabed (None if unknown)."""
    alt = float(state.altitude)
    return {
        "t": round(float(state.t), 6),
        "position": _r(state.position),
        "quat_wxyz": _r(state.quat_wxyz, 8),
        "rpy": _r(state.euler, 8),
        "velocity_body": _r(state.velocity_body),
        "altitude": round(alt, 6) if math.isfinite(alt) else None,
    }


def prepare_scenario(data: dict, seed: int) -> Scenario:
    """The scenario of one shard: seed set, SLAM and front end off, no recording/figures."""
    scn = parse_scenario(data).with_overrides(seed=seed)
    vehicles = tuple(
        replace(
            v,
            slam=replace(v.slam, estimator="none"),
            frontend=replace(v.frontend, method="none"),
        )
        for v in scn.vehicles
    )
    return replace(scn, vehicles=vehicles, outputs=OutputSpec(recording=False, figures=False))


def sonar_kind(preset_name: str) -> str:
    from sim.scenario.schema import SIDESCAN_PRESETS

    if preset_name in SIDESCAN_PRESETS:
        return "sss"
    return "msis" if preset_name == "msis" else "fls"


def fls_every(ping_rate_hz: float, interval_s: float) -> int:
    """Keep every k-th FLS ping: k = max(1, round(interval x rate))."""
    return max(1, round(interval_s * ping_rate_hz))


def frame_period(
    scn: Scenario, kinds: tuple[str, ...], tile_pings: int, fls_interval_s: float
) -> float:
    """Expected simulated seconds per exported frame over all selected sonars.

    Raises ValueError when the scenario carries no sonar of the selected kinds."""
    rate = 0.0
    found = {"sss": [], "fls": [], "msis": []}
    for v in scn.vehicles:
        for sp in v.sonars:
            k = sonar_kind(sp.preset)
            found[k].append(f"{v.name}/{sp.name} ({sp.preset})")
            if k not in kinds:
                continue
            hz = preset(sp.preset, **dict(sp.overrides)).ping_rate_hz
            rate += hz / tile_pings if k == "sss" else hz / fls_every(hz, fls_interval_s)
    if rate == 0.0:
        have = [k for k in ("sss", "fls") if found[k]]
        raise ValueError(
            f"kind = {'both' if len(kinds) == 2 else kinds[0]!r}: scenario {scn.name!r} carries no "
            f"{' or '.join(kinds)} sonar; its sonars: "
            + (", ".join(found["sss"] + found["fls"] + found["msis"]) or "none")
            + f"; allowed kinds for it: {', '.join(have) if have else 'none'}"
        )
    return 1.0 / rate


@dataclass
class _Track:
    vehicle: object
    sonar: object
    period: float
    next_t: float = 0.0
    buffer: list = field(default_factory=list)
    config: object = None


class ShardSimulation:
    """The world, autopilots and selected sonars of one shard (built by ScenarioRun).

    scn: a prepared scenario (:func:`prepare_scenario`); kinds: sonar kinds to fire
    ("sss", "fls"); tile_pings: pings per side-scan tile; fls_interval_s: s between
    exported FLS frames. ``objects`` lists the world's objects (sim.world ObjectInfo).
    """

    def __init__(
        self, scn: Scenario, kinds: tuple[str, ...], tile_pings: int, fls_interval_s: float
    ) -> None:
        self.scn = scn
        self.tile_pings = tile_pings
        # linear intensities out; display compression is redone by the exporter
        self.run = ScenarioRun(scn, linear_sonars=True)
        self.tracks: list[_Track] = []
        for v in self.run.vehicles:
            for s in v.sonars:
                if s.kind not in kinds:
                    continue
                cfg = preset(s.spec.preset, **dict(s.spec.overrides))  # as displayed
                k = fls_every(cfg.ping_rate_hz, fls_interval_s) if s.kind == "fls" else 1
                self.tracks.append(_Track(v, s, s.period * k, config=cfg))
        if not self.tracks:
            raise ValueError(f"scenario {scn.name!r} carries no sonar of kind {kinds}")

    @property
    def objects(self) -> list:
        return list(self.run.world.objects)

    def frames(
        self,
        n_frames: int,
        offset_s: float = 0.0,
        max_sim_s: float | None = None,
        accept: Callable[[SonarFrame], bool] | None = None,
    ) -> Iterator[SonarFrame]:
        """Yield ``n_frames`` frames in time order, recording from ``offset_s`` on (the
        vehicles fly there first, no sonar). ``accept`` (optional) filters frames; only
        accepted ones count and are numbered. Raises RuntimeError if fewer frames come
        within ``max_sim_s`` simulated seconds after the offset."""
        run, w, tracks = self.run, self.run.world, self.tracks
        dt_c = self.scn.control_dt
        n_tick = max(1, round(dt_c / w.timestep))
        pilots = [(v.handle, v.autopilot, None) for v in run.vehicles]  # truth: no nav here

        for _ in range(math.floor(offset_s / dt_c + 1e-9)):
            for handle, ap, _ in pilots:
                handle.apply_wrench_demand(ap.update(handle.state(), dt_c))
            w.step(n_tick)
        t0 = w.time
        for tr in tracks:
            tr.next_t = math.ceil(t0 / tr.period - 1e-9) * tr.period
            tr.buffer = []
        limit = t0 + (max_sim_s if max_sim_s is not None else math.inf)
        produced = 0
        fired: list[SonarFrame] = []

        def on_ping(k: int) -> None:
            frame = _fire(tracks[k], w, 0, self.tile_pings)
            if frame is not None:
                fired.append(frame)

        while produced < n_frames:
            if w.time > limit:
                raise RuntimeError(
                    f"only {produced} of {n_frames} frames"
                    + (" passed the frame filter" if accept is not None else "")
                    + f" in {w.time - t0:.0f} s of simulation after the offset {offset_s:g} s"
                )
            fired.clear()
            advance_tick(w, pilots, tracks, dt_c, on_ping)
            for frame in fired:  # numbered as they are accepted
                frame = replace(frame, index=produced)
                if accept is None or accept(frame):
                    yield frame
                    produced += 1
                    if produced >= n_frames:
                        return


def _fire(tr: _Track, w, index: int, tile_pings: int) -> SonarFrame | None:
    v, s = tr.vehicle, tr.sonar
    state = v.handle.state()
    base = {
        "vehicle": v.spec.name,
        "vehicle_kind": v.spec.kind,
        "sonar": s.spec.name,
        "preset": s.spec.preset,
        "config": tr.config,
    }
    if s.kind == "sss":
        tr.buffer.append((s.sonar.ping(w.data, s.rng), state))
        if len(tr.buffer) < tile_pings:
            return None
        pings, states = zip(*tr.buffer)
        tr.buffer = []
        c = len(pings) // 2
        alt = np.array([p.altitude for p in pings])
        geometry = {
            "layout": "rows = pings in time order; columns = port far->near, then starboard near->far",
            "samples_per_side": int(pings[0].samples_per_side),
            "slant_range_m": _r(pings[0].slant_range),
            "ping_time_s": _r([p.time for p in pings]),
            "ping_pose": {
                "position": _r([st.position for st in states]),
                "quat_wxyz": _r([st.quat_wxyz for st in states], 8),
                "rpy": _r([st.euler for st in states], 8),
            },
            "sonar_altitude_m": [None if not math.isfinite(a) else round(float(a), 6) for a in alt],
            "transducer_position": _r([p.sensor_position for p in pings]),
            "sensor_rotation_center_ping": _r(pings[c].sensor_rotation, 8),
        }
        return SonarFrame(
            index=index,
            kind="sss",
            linear=np.stack([p.intensity for p in pings]).astype(np.float32),
            labels=np.stack([p.labels for p in pings]).astype(np.int32),
            time=float(pings[c].time),
            pose=pose_dict(states[c]),
            geometry=geometry,
            **base,
        )
    fr = s.sonar.frame(w.data, s.rng)
    geometry = {
        "layout": "rows = range bins (row 0 nearest), columns = beams (column 0 = port edge, +fov/2)",
        "range_m": _r(fr.ranges),
        "bearing_rad": _r(fr.bearings, 8),
        "sensor_position": _r(fr.sensor_position),
        "sensor_rotation": _r(fr.sensor_rotation, 8),
    }
    return SonarFrame(
        index=index,
        kind="fls",
        linear=np.asarray(fr.image, np.float32),
        labels=np.asarray(fr.labels, np.int32),
        time=float(fr.time),
        pose=pose_dict(state),
        geometry=geometry,
        fls=fr,
        **base,
    )

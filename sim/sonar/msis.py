"""Mechanically scanned imaging sonar (MSIS): one fan beam rotating about the site's z axis.

Each ping fires one beam at the current head angle (bearing ccw from the sensor's x axis)
and the head then steps by ``step_deg``. A scan is a sequence of pings; the vehicle keeps
moving between pings (the caller's ``advance(dt)`` steps the physics), so every ping has
its own sensor pose — the motion distortion the reference thesis's MSIS SLAM handles.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import mujoco
import numpy as np

from sim.sonar.acoustics import beam_pattern, finish_samples, tvg_gain
from sim.sonar.config import MSISConfig, WaterLike
from sim.sonar.echo import form_echo
from sim.sonar.mount import SonarMount


@dataclass(frozen=True)
class MSISPing:
    """One beam. intensity (bins,) float32; labels (bins,) int32; hit_position (bins, 3);
    head_angle rad (bearing ccw from sensor x); sensor_position (3,); sensor_rotation (3, 3)
    world-from-sensor; time s."""

    intensity: np.ndarray
    labels: np.ndarray
    hit_position: np.ndarray
    head_angle: float
    sensor_position: np.ndarray
    sensor_rotation: np.ndarray
    time: float


@dataclass(frozen=True)
class MSISScan:
    """A scan. intensity (pings, bins) float32; ranges (bins,) m; head_angle (pings,) rad;
    labels (pings, bins); hit_position (pings, bins, 3); sensor_position (pings, 3);
    sensor_rotation (pings, 3, 3); time (pings,) s."""

    intensity: np.ndarray
    ranges: np.ndarray
    head_angle: np.ndarray
    labels: np.ndarray
    hit_position: np.ndarray
    sensor_position: np.ndarray
    sensor_rotation: np.ndarray
    time: np.ndarray

    def cells_to_world(self, ping: np.ndarray, bin_: np.ndarray) -> np.ndarray:
        """World xyz (K, 3) of cells (ping, bin) in the beam's axis direction (horizontal in
        the sensor frame, zero tilt), each with the pose of its own ping — the
        motion-compensated position a SLAM front end would compute."""
        ping = np.asarray(ping)
        a = self.head_angle[ping]
        r = self.ranges[np.asarray(bin_)]
        local = np.stack([r * np.cos(a), r * np.sin(a), np.zeros_like(r)], -1)
        return self.sensor_position[ping] + np.einsum(
            "kij,kj->ki", self.sensor_rotation[ping], local
        )


class MSISSonar:
    """MSIS on one site. Arguments as :class:`sim.sonar.sidescan.SideScanSonar`."""

    def __init__(
        self,
        config: MSISConfig,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        site_id: int,
        geom_object_id: np.ndarray,
        geom_reflectivity: np.ndarray,
        water: WaterLike,
        backend="embree",
        static_mesh=None,
    ):
        self.mount = SonarMount(
            config,
            model,
            data,
            (site_id,),
            geom_object_id,
            geom_reflectivity,
            water,
            backend,
            static_mesh,
        )
        self.config = c = config
        self.bin_width = c.bin_width
        self.ranges = c.bin_centres
        hbw = np.deg2rad(c.horizontal_beamwidth_deg)
        vbw = np.deg2rad(c.vertical_beamwidth_deg)
        tilt = np.deg2rad(c.tilt_deg)
        f = 1.0 if c.beam_pattern == "rect" else 1.5
        nh, nv = c.rays_horizontal, c.rays_vertical
        az = ((np.arange(nh) + 0.5) / nh - 0.5) * f * hbw
        el = -tilt + ((np.arange(nv) + 0.5) / nv - 0.5) * f * vbw
        A, E = np.meshgrid(az, el, indexing="ij")
        self._az = A.reshape(-1)
        self._el = E.reshape(-1)
        dE = f * vbw / nv
        dA = f * hbw / nh
        b = (
            beam_pattern(A, hbw, c.beam_pattern, c.sidelobe_db)
            * beam_pattern(E + tilt, vbw, c.beam_pattern, c.sidelobe_db)
        ) ** 2
        self._gain = (b * np.cos(E) * dA * dE).reshape(-1) * self.mount.sl * self.mount.mu
        self._dE = dE
        self.head_angle = np.deg2rad(c.sector_center_deg - c.sector_deg / 2.0)
        self._zero_rows = np.zeros(self._az.size, np.int64)
        j = np.arange(nh * nv).reshape(nh, nv)
        self._neighbours = (j % nv < nv - 1).reshape(-1)[:-1]  # j and j+1 in the same column
        self._tvg = tvg_gain(self.ranges, self.mount.alpha_db_m, c.acoustic.tvg)

    def head_angles(self) -> np.ndarray:
        """Head angles (rad) of one scan's pings, starting at the sector's start."""
        c = self.config
        start = np.deg2rad(c.sector_center_deg - c.sector_deg / 2.0)
        return start + np.deg2rad(c.step_deg) * np.arange(c.n_steps)

    def ping(self, data: mujoco.MjData, rng: np.random.Generator, head_angle: float) -> MSISPing:
        """One beam at ``head_angle`` (rad) at the current state of ``data``."""
        c = self.config
        m = self.mount
        p, R = m.pose(data, m.site_ids[0])
        a = head_angle + self._az
        ce, se = np.cos(self._el), np.sin(self._el)
        d_local = np.stack([ce * np.cos(a), ce * np.sin(a), se], -1)
        dd_local = np.stack([-se * np.cos(a), -se * np.sin(a), ce], -1) * self._dE
        dirs = d_local @ R.T
        hits = m.backend.cast(data, p, dirs, m.cutoff)
        echo = form_echo(
            hits,
            p,
            dirs,
            dd_local @ R.T,
            self._gain,
            self._zero_rows,
            1,
            c.n_bins,
            c.min_range,
            self.bin_width,
            m.geom_object_id,
            m.geom_reflectivity,
            m.alpha_db_m,
            m.specular,
            1.0,
            self._neighbours,
        )
        inten = finish_samples(echo.mean[0], self.ranges, m.alpha_db_m, c.acoustic, rng, self._tvg)
        return MSISPing(
            inten, echo.labels[0], echo.hit_position[0], float(head_angle), p, R, float(data.time)
        )

    def scan(
        self,
        data: mujoco.MjData,
        rng: np.random.Generator,
        advance: Callable[[float], None] | None = None,
    ) -> MSISScan:
        """A full scan (``config.n_steps`` pings). Between pings ``advance(1 / ping_rate_hz)``
        is called to move the world on (e.g. ``lambda dt: world.step(round(dt / world.timestep))``);
        without it the vehicle stands still."""
        dt = 1.0 / self.config.ping_rate_hz
        pings = []
        angles = self.head_angles()
        for k, a in enumerate(angles):  # one iteration per ping (rays are vectorized)
            pings.append(self.ping(data, rng, float(a)))
            if advance is not None and k + 1 < angles.size:
                advance(dt)
        return MSISScan(
            intensity=np.stack([q.intensity for q in pings]),
            ranges=self.ranges,
            head_angle=angles.copy(),
            labels=np.stack([q.labels for q in pings]),
            hit_position=np.stack([q.hit_position for q in pings]),
            sensor_position=np.stack([q.sensor_position for q in pings]),
            sensor_rotation=np.stack([q.sensor_rotation for q in pings]),
            time=np.array([q.time for q in pings]),
        )


def msis_scan(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    site_id: int,
    geom_object_id: np.ndarray,
    geom_reflectivity: np.ndarray,
    water: WaterLike,
    rng: np.random.Generator,
    config: MSISConfig | None = None,
    advance: Callable[[float], None] | None = None,
    backend: str = "mujoco",
) -> MSISScan:
    """One-shot scan (builds an :class:`MSISSonar`)."""
    from sim.sonar.config import preset

    cfg = config if config is not None else preset("msis")
    return MSISSonar(
        cfg, model, data, site_id, geom_object_id, geom_reflectivity, water, backend
    ).scan(data, rng, advance)

"""Side-scan sonar: the ray fan of each ping, its cast and its echo (the data products,
waterfall, ground-range image and mosaic: :mod:`sim.sonar.waterfall`).

Geometry: the sensor frame is the site frame (x forward, y port, z up). Each side casts a
fan of rays in the across-track plane at depression angles θ (below horizontal, from
``depression − vertical_beamwidth`` up to nadir, 90°) and a few along-track angles ψ
across the along-track beam. The depression angles are the union of a uniform grid (``angular_grid_deg``)
and a grid that lands rays at uniform slant-range steps on a flat seabed at the altitude
measured by a nadir probe (``ray_oversampling`` rays per bin), so shadows are sharp at
every range. Intensity layout per ping: ``(2 × samples,)``, port on the left with far
range first, nadir in the middle, starboard on the right.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import mujoco
import numpy as np

from sim.sonar.acoustics import beam_pattern, tvg_gain
from sim.sonar.chain import SideScanChain
from sim.sonar.config import SSSConfig, WaterLike
from sim.sonar.echo import Echo, form_echo
from sim.sonar.glint import corner_returns
from sim.sonar.mount import SonarMount
from sim.sonar.rays import RayCones, RayHits, ray_cones
from sim.sonar.sss_kernels import ping_samples, probe_altitude
from sim.sonar.waterfall import SSSPing

_PROBE_DEG = np.array([60.0, 65.0, 70.0, 75.0, 80.0, 85.0, 90.0])


@dataclass(frozen=True)
class RayFan:
    """The rays of one SSS ping in the sensor frame: directions (N, 3) unit; d_directions
    (N, 3) = ∂d/∂θ·Δθ; gain (N,) SL·b²·ΔΩ·μ; rows (N,) 0 port / 1 starboard; neighbours
    (N − 1,) bool, True where rays j and j + 1 are consecutive in θ; cones: bounding
    cones (sensor frame) of ``directions`` followed by the nadir probe's rays;
    side_cones: (port, starboard) cones of each side's directions for a two-site sonar
    (each side cast from its own site; None for one site); port_probe_cones: a two-site
    sonar's cones of the port directions followed by the probe's (cast together from the
    port site; None for one site); local:
    (2N + P, 3) the directions, the P probe rays and the d_directions in one array (one
    rotation per ping turns all three into the world frame; ``directions`` and
    ``d_directions`` are views of it)."""

    local: np.ndarray
    directions: np.ndarray
    d_directions: np.ndarray
    gain: np.ndarray
    rows: np.ndarray
    neighbours: np.ndarray
    cones: RayCones
    side_cones: tuple[RayCones, RayCones] | None = None
    port_probe_cones: RayCones | None = None


class SideScanSonar:
    """Side-scan sonar on one site (both sides) or two sites (port, starboard).

    Parameters: config (:class:`SSSConfig`, e.g. ``preset("deepeye680d")``); model, data
    (after ``mj_forward``); site_id: int or (port_site, starboard_site); geom_object_id
    (ngeom,) int; geom_reflectivity (ngeom,) float; water (``WaterLike``); backend
    "embree" (static scene in Embree + moving bodies in MuJoCo) or "mujoco"; static_mesh:
    optional world-frame (V, F, geom per face), e.g. ``World.static_mesh()``.
    """

    def __init__(
        self,
        config: SSSConfig,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        site_id: int | tuple[int, int],
        geom_object_id: np.ndarray,
        geom_reflectivity: np.ndarray,
        water: WaterLike,
        backend="embree",
        static_mesh=None,
    ):
        sites = (site_id, site_id) if isinstance(site_id, int | np.integer) else tuple(site_id)
        if len(sites) != 2:
            raise ValueError(
                f"site_id = {site_id!r}; allowed: one site or (port_site, starboard_site)"
            )
        self.mount = SonarMount(
            config,
            model,
            data,
            sites,
            geom_object_id,
            geom_reflectivity,
            water,
            backend,
            static_mesh,
        )
        self.config = config
        c = config
        S = c.samples_per_side
        self.bin_width = c.bin_width
        self.ranges = c.min_range + (np.arange(S) + 0.5) * self.bin_width
        self.slant_range = np.concatenate([self.ranges[::-1], self.ranges])
        self.dep = np.deg2rad(c.depression_deg)
        self.vbw = np.deg2rad(c.vertical_beamwidth_deg)
        self.theta_lo = max(np.deg2rad(-30.0), self.dep - self.vbw)
        bw = np.deg2rad(c.along_track_beamwidth_deg)
        span = bw if c.beam_pattern == "rect" else 2.0 * bw
        n = c.rays_along_track
        self.psi = (np.arange(n) + 0.5) / n * span - 0.5 * span
        self.dpsi = span / n
        self.b_along = beam_pattern(self.psi, bw, c.beam_pattern, c.sidelobe_db) ** 2
        self.uniform_theta = np.arange(self.theta_lo, np.pi / 2, np.deg2rad(c.angular_grid_deg))
        probe = np.deg2rad(_PROBE_DEG)
        self._probe_local = np.concatenate(
            [
                np.stack([np.zeros_like(probe), np.cos(probe), -np.sin(probe)], 1),
                np.stack([np.zeros_like(probe), -np.cos(probe), -np.sin(probe)], 1),
            ]
        )
        self._fan_cache = None
        # the plain receive chain's gain and noise (as acoustics.finish_samples forms them)
        self._tvg = tvg_gain(self.ranges, self.mount.alpha_db_m, c.acoustic.tvg)
        self._noise = 10.0 ** (c.acoustic.noise_level_db / 10.0)
        rz = c.acoustic.realism
        self.chain = SideScanChain(c, self.mount, self.ranges) if rz is not None else None

    # -- geometry -----------------------------------------------------------------------
    def _altitude(self, data, origin, R, dirs=None, dist=None) -> float:
        """Median vertical distance (m) from the transducer down to the probe rays' hits
        (7 rays per side at 60°–90° depression in the sensor frame) within ``max_range``;
        NaN if none hit. ``dirs``, ``dist``: the probe's world directions and hit
        distances when already cast (with the ping's rays)."""
        if dist is None:
            dirs = self._probe_local @ np.ascontiguousarray(R.T)
            dist = self.mount.backend.cast(data, origin, dirs, self.config.max_range).dist
        return float(probe_altitude(dirs, dist, float(self.config.max_range)))

    def _cast_ping(self, data, origin, R):
        """Altitude (m), the ping's fan, its world directions (N, 3) and ∂d/∂θ·Δθ (N, 3)
        and the hits of the rays cast from ``origin``: all N (one site) or the port half
        (two sites; the starboard half is cast from its own site). The nadir probe is
        cast in one batch with the cached fan's rays; they are cast again only when the
        probe's altitude selects another fan (each ray's hit does not depend on the
        batch, so the result equals probing first and casting the fan after).
        ``fan.local @ R.T`` rotates rays, probe and derivatives in one product (a
        contiguous Rᵀ: OpenBLAS's fast path, the same bytes)."""
        m = self.mount
        Rt = np.ascontiguousarray(R.T)
        prev = self._fan_cache[1] if self._fan_cache is not None else None
        n_p = self._probe_local.shape[0]
        two = prev is not None and prev.port_probe_cones is not None
        if prev is None:
            altitude = self._altitude(data, origin, R)
        else:
            n = prev.directions.shape[0]
            nc = n // 2 if two else n
            world = prev.local @ Rt
            both = np.concatenate([world[:nc], world[n : n + n_p]]) if two else world[: n + n_p]
            cones = prev.port_probe_cones if two else prev.cones
            h = m.backend.cast(data, origin, both, m.cutoff, cones.rotated(R))
            altitude = self._altitude(data, origin, R, both[nc:], h.dist[nc:])
        fan = self.ray_fan(altitude)
        if fan is prev:
            hits = RayHits(h.dist[:nc], h.geom[:nc], h.normal[:nc])
            return altitude, fan, world[:n], world[n + n_p :], hits
        n = fan.directions.shape[0]
        two = fan.port_probe_cones is not None
        nc = n // 2 if two else n
        world = fan.local @ Rt
        dirs = world[:n]
        cones = replace((fan.port_probe_cones if two else fan.cones).rotated(R), n=nc)
        hits = m.backend.cast(data, origin, dirs[:nc], m.cutoff, cones)
        return altitude, fan, dirs, world[n + n_p :], hits

    def depression_angles(self, altitude: float) -> tuple[np.ndarray, np.ndarray]:
        """Depression angles θ (rad) of the rays of one fan and their angular widths Δθ.

        Cell edges are the union of the uniform ``angular_grid_deg`` grid and the angles at which a flat seabed at
        ``altitude`` lies at uniform slant-range steps (``ray_oversampling`` per bin, out to
        the cast cutoff); each ray sits at the centre of its cell so its range footprint is
        centred on its hit (footprints then tile the range axis)."""
        c = self.config
        edges = [self.uniform_theta, [np.pi / 2]]
        if np.isfinite(altitude) and altitude < self.mount.cutoff:
            r0 = max(altitude, c.min_range)
            r1 = 1.02 * c.max_range  # rays further out come from the uniform grid
            n = int(np.ceil(c.ray_oversampling * (r1 - r0) / self.bin_width)) + 1
            r = np.linspace(r0, r1, n)
            edges.append(np.arcsin(np.clip(altitude / r, -1.0, 1.0)))
        e = np.unique(np.concatenate(edges))
        e = e[e >= self.theta_lo]
        return 0.5 * (e[1:] + e[:-1]), np.diff(e)

    def clear_cache(self) -> None:
        """Forget the cached ray fan: the next ping starts as a new sonar's first does
        (an environment reset must not depend on the previous episode)."""
        self._fan_cache = None

    def ray_fan(self, altitude: float) -> RayFan:
        """Both sides' rays for a ping at ``altitude`` (m; NaN: no bottom found). The fan
        is rebuilt only when the altitude moved by two bins (footprints adapt to the actual
        hits, so a slightly stale ray distribution only changes the sampling density)."""
        key = round(altitude / (2.0 * self.bin_width)) if np.isfinite(altitude) else None
        if self._fan_cache is not None and self._fan_cache[0] == key:
            return self._fan_cache[1]
        theta, dtheta = self.depression_angles(altitude)
        parts = [self._fan(theta, dtheta, s) for s in (1.0, -1.0)]
        d_loc = np.concatenate([parts[0][0], parts[1][0]])
        nt = theta.size
        n = d_loc.shape[0]
        j = np.arange(n)
        local = np.concatenate([d_loc, self._probe_local, parts[0][1], parts[1][1]])
        one_site = self.mount.site_ids[0] == self.mount.site_ids[1]
        fan = RayFan(
            local=local,
            directions=local[:n],
            d_directions=local[n + self._probe_local.shape[0] :],
            gain=np.concatenate([parts[0][2], parts[1][2]]),
            rows=np.repeat(np.array([0, 1], np.int64), parts[0][0].shape[0]),
            neighbours=(j % nt < nt - 1)[:-1],
            cones=ray_cones(np.concatenate([d_loc, self._probe_local])),
            side_cones=None
            if one_site
            else (ray_cones(d_loc[: n // 2]), ray_cones(d_loc[n // 2 :])),
            port_probe_cones=(
                None
                if one_site
                else ray_cones(np.concatenate([d_loc[: n // 2], self._probe_local]))
            ),
        )
        self._fan_cache = (key, fan)
        return fan

    def _fan(self, theta, dtheta, side_sign):
        """Local directions (N, 3), ∂d/∂θ·Δθ (N, 3) and beam gains (N,) of one side."""
        psi = self.psi[:, None]
        ct, st = np.cos(theta)[None, :], np.sin(theta)[None, :]
        cp, sp = np.cos(psi), np.sin(psi)
        d = np.stack(np.broadcast_arrays(sp, side_sign * cp * ct, -cp * st), -1).reshape(-1, 3)
        dd = np.stack(np.broadcast_arrays(0.0 * sp, -side_sign * cp * st, -cp * ct), -1)
        dd = (dd * dtheta[None, :, None]).reshape(-1, 3)
        c = self.config
        bv = beam_pattern(theta - self.dep, self.vbw, c.beam_pattern, c.sidelobe_db) ** 2
        gain = (self.b_along[:, None] * cp * self.dpsi) * (bv * dtheta)[None, :]
        return d, dd, (gain * self.mount.sl * self.mount.mu).reshape(-1)

    def _add_corners(self, mean, hits, origin, dirs, gain, rows):
        """mean plus the objects' corner returns (when ``corner_gain_db`` is set)."""
        m, c = self.mount, self.config
        rz = m.realism
        if rz is None or rz.corner_gain_db is None:
            return mean
        extra = corner_returns(
            m.backend,
            origin,
            dirs,
            hits,
            gain,
            rows,
            m.geom_object_id,
            m.geom_reflectivity,
            10.0 ** (rz.corner_gain_db / 10.0) / m.mu,
            np.deg2rad(rz.corner_width_deg),
            m.alpha_db_m,
            c.min_range,
            self.bin_width,
            mean.shape[0],
            mean.shape[1],
        )
        return mean if extra is None else mean + extra

    # -- ping ---------------------------------------------------------------------------
    def ping(self, data: mujoco.MjData, rng: np.random.Generator) -> SSSPing:
        """Simulate one ping at the current state of ``data`` (positions from mj_forward/step)."""
        c = self.config
        m = self.mount
        S = c.samples_per_side
        p_port, R = m.pose(data, m.site_ids[0])
        p_stbd, _ = m.pose(data, m.site_ids[1])
        altitude, fan, dirs, d_dirs, hits = self._cast_ping(data, p_port, R)
        gain, rows, nbrs = fan.gain, fan.rows, fan.neighbours
        n_side = dirs.shape[0] // 2
        if m.site_ids[0] == m.site_ids[1]:
            echo = form_echo(
                hits,
                p_port,
                dirs,
                d_dirs,
                gain,
                rows,
                2,
                S,
                c.min_range,
                self.bin_width,
                m.geom_object_id,
                m.geom_reflectivity,
                m.alpha_db_m,
                m.specular,
                1.0,
                nbrs,
                m.seabed,
                m.object_specular,
                m.object_gain,
                ping_layout=True,
            )
            mean, labels, pos = echo.mean, echo.labels, echo.hit_position  # pos: ping layout
            mean = self._add_corners(mean, hits, p_port, dirs, gain, rows)
        else:
            out = []
            for k, p in enumerate((p_port, p_stbd)):
                sl = slice(k * n_side, (k + 1) * n_side)
                h = (
                    hits  # the port side's, cast with the probe
                    if k == 0
                    else m.backend.cast(data, p, dirs[sl], m.cutoff, fan.side_cones[k].rotated(R))
                )
                out.append(
                    form_echo(
                        h,
                        p,
                        dirs[sl],
                        d_dirs[sl],
                        gain[sl],
                        np.zeros(n_side, np.int64),
                        1,
                        S,
                        c.min_range,
                        self.bin_width,
                        m.geom_object_id,
                        m.geom_reflectivity,
                        m.alpha_db_m,
                        m.specular,
                        1.0,
                        nbrs[: n_side - 1],
                        m.seabed,
                        m.object_specular,
                        m.object_gain,
                    )
                )
                out[-1] = Echo(
                    self._add_corners(
                        out[-1].mean, h, p, dirs[sl], gain[sl], np.zeros(n_side, np.int64)
                    ),
                    out[-1].labels,
                    out[-1].hit_position,
                )
            mean = np.concatenate([e.mean for e in out])
            labels = np.concatenate([e.labels for e in out])
            pos = np.concatenate([out[0].hit_position[0, ::-1], out[1].hit_position[0]])
        if self.chain is not None:
            inten = self.chain.finish(mean, altitude, 0.5 * (p_port + p_stbd), rng)
            inten = np.concatenate([inten[0, ::-1], inten[1]])
        else:
            inten = ping_samples(mean, c.acoustic, rng, self._tvg, self._noise)
        return SSSPing(
            intensity=inten,
            slant_range=self.slant_range,
            labels=np.concatenate([labels[0, ::-1], labels[1]]),
            hit_position=pos,
            sensor_position=np.stack([p_port, p_stbd]),
            sensor_rotation=R,
            time=float(data.time),
            altitude=altitude,
        )


def sss_ping(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    site_id: int | tuple[int, int],
    geom_object_id: np.ndarray,
    geom_reflectivity: np.ndarray,
    water: WaterLike,
    rng: np.random.Generator,
    config: SSSConfig | None = None,
    backend: str = "mujoco",
) -> SSSPing:
    """One-shot ping (builds a :class:`SideScanSonar`; keep one for repeated pings)."""
    from sim.sonar.config import preset

    cfg = config if config is not None else preset("deepeye680d")
    sonar = SideScanSonar(
        cfg, model, data, site_id, geom_object_id, geom_reflectivity, water, backend
    )
    return sonar.ping(data, rng)

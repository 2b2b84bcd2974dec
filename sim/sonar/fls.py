"""Forward-looking multibeam imaging sonar (FLS): polar (bins, beams) image and fan image.

Beams are spread uniformly across the horizontal field of view, beam 0 at +fov/2 (port,
left of the image) to beam n−1 at −fov/2 (starboard); bearings are counter-clockwise from
the sensor's x axis. Each beam casts ``rays_per_beam`` rays across the vertical aperture
(elevation from −tilt − vfov/2 to −tilt + vfov/2; 1.5× that for non-rect patterns),
spread across the beam's horizontal cell. Echo formation as in
:mod:`sim.sonar.echo` (footprint splatting, Lambert + specular, spreading, absorption).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import mujoco
import numpy as np

from sim.sonar.acoustics import beam_pattern, finish_samples, tvg_gain
from sim.sonar.config import FLSConfig, WaterLike
from sim.sonar.echo import form_echo
from sim.sonar.glint import add_azimuth_sidelobes, azimuth_sidelobe_kernel, corner_returns
from sim.sonar.mount import SonarMount
from sim.sonar.rays import ray_cones


@dataclass(frozen=True)
class FLSFrame:
    """One FLS frame. image: (bins, beams) float32 (row 0 = nearest bin); ranges: (bins,) m
    bin centres; bearings: (beams,) rad, ccw from sensor x (beam 0 = +fov/2, port);
    labels: (bins, beams) int32 (0 seabed, k object, −1 none, −2 other geom);
    hit_position: (bins, beams, 3) world m (NaN where label −1); sensor_position (3,),
    sensor_rotation (3, 3) world-from-sensor; time s."""

    image: np.ndarray
    ranges: np.ndarray
    bearings: np.ndarray
    labels: np.ndarray
    hit_position: np.ndarray
    sensor_position: np.ndarray
    sensor_rotation: np.ndarray
    time: float

    def cell_of(self, r: float, bearing: float) -> tuple[int, int]:
        """(bin, beam) of the cell containing range r (m) and bearing (rad)."""
        dr = self.ranges[1] - self.ranges[0]
        db = self.bearings[0] - self.bearings[1]
        i = int(np.floor((r - (self.ranges[0] - 0.5 * dr)) / dr))
        j = int(np.round((self.bearings[0] - bearing) / db))
        return i, j


class ForwardLookingSonar:
    """FLS on one site. Arguments as :class:`sim.sonar.sidescan.SideScanSonar`."""

    def __init__(
        self,
        config: FLSConfig,
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
        fov = np.deg2rad(c.horizontal_fov_deg)
        nb = c.n_beams
        self.bearings = (0.5 - (np.arange(nb) + 0.5) / nb) * fov
        dbeta = fov / nb
        vfov = np.deg2rad(c.vertical_fov_deg)
        tilt = np.deg2rad(c.tilt_deg)
        nr = c.rays_per_beam
        span = vfov if c.beam_pattern == "rect" else 1.5 * vfov
        eps = -tilt + ((np.arange(nr) + 0.5) / nr - 0.5) * span
        deps = span / nr
        # rays of a beam: stratified in elevation, spread across the beam's horizontal cell by
        # a golden-ratio sequence so small targets between beam centres are still hit
        jitter = (np.mod(np.arange(nr) * 0.6180339887, 1.0) - 0.5) * dbeta
        B = self.bearings[:, None] + jitter[None, :]
        E = np.broadcast_to(eps[None, :], B.shape)
        ce, se, cb, sb = np.cos(E), np.sin(E), np.cos(B), np.sin(B)
        self._d_local = np.stack([ce * cb, ce * sb, se], -1).reshape(-1, 3)
        self._dd_local = (np.stack([-se * cb, -se * sb, ce], -1) * deps).reshape(-1, 3)
        bv = beam_pattern(E + tilt, vfov, c.beam_pattern, c.sidelobe_db) ** 2
        self._gain = (bv * ce * deps * dbeta).reshape(-1) * self.mount.sl * self.mount.mu
        self._rows = np.repeat(np.arange(nb, dtype=np.int64), nr)
        j = np.arange(nb * nr).reshape(nb, nr)
        self._neighbours = (j % nr < nr - 1).reshape(-1)[:-1]  # j and j+1 in the same beam
        self._sidelobes = None
        self._cones = ray_cones(self._d_local)  # bounds for the moving-body test
        self._tvg = tvg_gain(self.ranges, self.mount.alpha_db_m, c.acoustic.tvg)

    def _realism(self, mean, hits, origin, dirs):
        """Mean image plus the objects' corner returns and the azimuth sidelobes of the
        receive beams (each when its RealismConfig field is set)."""
        m, c = self.mount, self.config
        rz = m.realism
        if rz is None:
            return mean
        if rz.corner_gain_db is not None:
            extra = corner_returns(
                m.backend,
                origin,
                dirs,
                hits,
                self._gain,
                self._rows,
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
            if extra is not None:
                mean = mean + extra
        if rz.fls_azimuth_sidelobe_db is not None:
            if self._sidelobes is None:
                fov = np.deg2rad(c.horizontal_fov_deg)
                self._sidelobes = azimuth_sidelobe_kernel(
                    c.n_beams,
                    fov / c.n_beams,
                    np.deg2rad(c.beamwidth_deg),
                    rz.fls_azimuth_sidelobe_db,
                )
            mean = add_azimuth_sidelobes(mean, self._sidelobes)
        return mean

    @property
    def rays_per_frame(self) -> int:
        return self._d_local.shape[0]

    def frame(self, data: mujoco.MjData, rng: np.random.Generator) -> FLSFrame:
        """Simulate one frame at the current state of ``data``."""
        c = self.config
        m = self.mount
        site = m.site_ids[0]
        p, R = m.pose(data, site)
        dirs = self._d_local @ R.T
        d_dirs = self._dd_local @ R.T
        hits = m.backend.cast(data, p, dirs, m.cutoff, self._cones.rotated(R))
        echo = form_echo(
            hits,
            p,
            dirs,
            d_dirs,
            self._gain,
            self._rows,
            c.n_beams,
            c.n_bins,
            c.min_range,
            self.bin_width,
            m.geom_object_id,
            m.geom_reflectivity,
            m.alpha_db_m,
            m.specular,
            1.0,
            self._neighbours,
            m.seabed,
            m.object_specular,
            m.object_gain,
            bins_first=True,
        )
        mean = self._realism(echo.mean, hits, p, dirs)
        img = finish_samples(mean, self.ranges, m.alpha_db_m, c.acoustic, rng, self._tvg)
        return FLSFrame(
            image=np.ascontiguousarray(img.T),
            ranges=self.ranges,
            bearings=self.bearings,
            labels=np.ascontiguousarray(echo.labels.T),
            hit_position=echo.hit_position,
            sensor_position=p,
            sensor_rotation=R,
            time=float(data.time),
        )


def fls_frame(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    site_id: int,
    geom_object_id: np.ndarray,
    geom_reflectivity: np.ndarray,
    water: WaterLike,
    rng: np.random.Generator,
    config: FLSConfig | None = None,
    backend: str = "mujoco",
) -> FLSFrame:
    """One-shot frame (builds a :class:`ForwardLookingSonar`; keep one for repeated frames)."""
    from sim.sonar.config import preset

    cfg = config if config is not None else preset("blueview_p900_90")
    return ForwardLookingSonar(
        cfg, model, data, site_id, geom_object_id, geom_reflectivity, water, backend
    ).frame(data, rng)


@dataclass(frozen=True)
class FanImage:
    """Cartesian fan: image (H, W) float32 (0 outside the fan), mask (H, W) bool inside the
    fan; pixel (i, j) centre at forward x = x_max − (i + ½)·res, lateral y = y_max − (j + ½)·res
    in the sensor's horizontal frame (y to port = image left)."""

    image: np.ndarray
    mask: np.ndarray
    x_max: float
    y_max: float
    resolution: float

    def pixel_to_xy(self, i, j) -> tuple[np.ndarray, np.ndarray]:
        return self.x_max - (np.asarray(i) + 0.5) * self.resolution, self.y_max - (
            np.asarray(j) + 0.5
        ) * self.resolution

    def pixel_to_range_bearing(self, i, j) -> tuple[np.ndarray, np.ndarray]:
        x, y = self.pixel_to_xy(i, j)
        return np.hypot(x, y), np.arctan2(y, x)

    def xy_to_pixel(self, x, y) -> tuple[np.ndarray, np.ndarray]:
        return (
            np.floor((self.x_max - np.asarray(x)) / self.resolution).astype(int),
            np.floor((self.y_max - np.asarray(y)) / self.resolution).astype(int),
        )


def fan_image(frame: FLSFrame, resolution: float | None = None) -> FanImage:
    """Scan-convert the polar image to a Cartesian fan (``cv2.remap``, bilinear): each
    pixel reads the polar image at its range and bearing. resolution defaults to the bin
    width (m)."""
    ranges, bearings = frame.ranges, frame.bearings
    dr = float(ranges[1] - ranges[0]) if ranges.size > 1 else 1.0
    res = dr if resolution is None else float(resolution)
    if res <= 0:
        raise ValueError(f"resolution = {resolution!r}; allowed > 0 m")
    rmax = float(ranges[-1] + 0.5 * dr)
    half = float(max(abs(bearings[0]), abs(bearings[-1])))
    db = float(bearings[0] - bearings[1]) if bearings.size > 1 else 1.0
    half_edge = half + 0.5 * db
    y_max = rmax * np.sin(min(half_edge, np.pi / 2))
    x_min = min(0.0, rmax * np.cos(half_edge))
    H = int(np.ceil((rmax - x_min) / res))
    W = int(np.ceil(2 * y_max / res))
    i, j = np.mgrid[0:H, 0:W]
    x = rmax - (i + 0.5) * res
    y = y_max - (j + 0.5) * res
    r = np.hypot(x, y)
    b = np.arctan2(y, x)
    row = ((r - ranges[0]) / dr).astype(np.float32)  # polar row coordinate (bin index)
    col = ((bearings[0] - b) / db).astype(np.float32)  # polar column coordinate (beam index)
    img = cv2.remap(
        frame.image.astype(np.float32),
        col,
        row,
        interpolation=cv2.INTER_LINEAR,
        borderMode=cv2.BORDER_CONSTANT,
        borderValue=0.0,
    )
    mask = (r >= ranges[0] - 0.5 * dr) & (r <= rmax) & (np.abs(b) <= half_edge)
    img[~mask] = 0.0
    return FanImage(img, mask, rmax, float(y_max), res)

"""Side-scan data products: the ping, the waterfall of pings, slant-to-ground-range
correction and the north-up mosaic (the sonar that makes the pings:
:mod:`sim.sonar.sidescan`).

Intensity layout per ping: ``(2 × samples,)``, port on the left with far range first,
nadir in the middle, starboard on the right.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage


@dataclass(frozen=True)
class SSSPing:
    """One side-scan ping.

    intensity: (2S,) float32, port far→near then starboard near→far (log-compressed to
    [0, 1] if configured, else linear µPa² after TVG). slant_range: (2S,) m, bin centre of
    each sample. labels: (2S,) int32, 0 seabed, k ≥ 1 object k, −1 no return, −2 other
    geom (vehicle). hit_position: (2S, 3) world m (NaN where label −1).
    sensor_position: (2, 3) world m of the port and starboard transducers;
    sensor_rotation: (3, 3) world-from-sensor (columns x fwd, y port, z up); time: s;
    altitude: m, nadir-probe altitude (what bottom tracking reports; NaN if no bottom).
    """

    intensity: np.ndarray
    slant_range: np.ndarray
    labels: np.ndarray
    hit_position: np.ndarray
    sensor_position: np.ndarray
    sensor_rotation: np.ndarray
    time: float
    altitude: float

    @property
    def samples_per_side(self) -> int:
        return self.intensity.shape[0] // 2

    def side(self, name: str) -> np.ndarray:
        """Intensities of one side ordered near → far ("port" or "starboard")."""
        s = self.samples_per_side
        if name == "port":
            return self.intensity[:s][::-1]
        if name == "starboard":
            return self.intensity[s:]
        raise ValueError(f"side = {name!r}; allowed: 'port', 'starboard'")


@dataclass(frozen=True)
class SideScanWaterfall:
    """Pings stacked in time. intensity (P, 2S) float32 (port left, nadir centre);
    slant_range (2S,) m; labels (P, 2S) int32; hit_position (P, 2S, 3) world m;
    sensor_position (P, 2, 3); sensor_rotation (P, 3, 3); time (P,) s; altitude (P,) m."""

    intensity: np.ndarray
    slant_range: np.ndarray
    labels: np.ndarray
    hit_position: np.ndarray
    sensor_position: np.ndarray
    sensor_rotation: np.ndarray
    time: np.ndarray
    altitude: np.ndarray

    @classmethod
    def from_pings(cls, pings: list[SSSPing]) -> SideScanWaterfall:
        if not pings:
            raise ValueError("pings is empty; allowed: at least one SSSPing")
        return cls(
            intensity=np.stack([p.intensity for p in pings]),
            slant_range=pings[0].slant_range,
            labels=np.stack([p.labels for p in pings]),
            hit_position=np.stack([p.hit_position for p in pings]),
            sensor_position=np.stack([p.sensor_position for p in pings]),
            sensor_rotation=np.stack([p.sensor_rotation for p in pings]),
            time=np.array([p.time for p in pings]),
            altitude=np.array([p.altitude for p in pings]),
        )

    @property
    def samples_per_side(self) -> int:
        return self.intensity.shape[1] // 2


def ground_range(slant_range: np.ndarray, altitude: float | np.ndarray) -> np.ndarray:
    """Flat-seabed ground range sqrt(r² − h²) (m); NaN inside the water column (r < h)."""
    r = np.asarray(slant_range, float)
    h = np.asarray(altitude, float)
    g2 = r * r - h * h
    return np.where(g2 >= 0, np.sqrt(np.maximum(g2, 0.0)), np.nan)


@dataclass(frozen=True)
class GroundRangeImage:
    """Slant-range-corrected waterfall: image (P, 2G) float32, port half on the left (far
    range first), starboard half on the right; ground_range (2G,) m, the unsigned ground
    range of each column; side (2G,) "port" / "starboard"."""

    image: np.ndarray
    ground_range: np.ndarray
    side: np.ndarray


def slant_to_ground(
    wf: SideScanWaterfall, resolution: float | None = None, max_ground_range: float | None = None
) -> GroundRangeImage:
    """Resample every ping from slant range to ground range on a flat-seabed model with the
    ping's altitude: column at ground range x reads slant range sqrt(x² + h²) (linear
    interpolation, ``scipy.ndimage.map_coordinates``). Water-column samples disappear."""
    S = wf.samples_per_side
    ranges = wf.slant_range[S:]
    dr = float(ranges[1] - ranges[0])
    r0 = float(ranges[0] - 0.5 * dr)
    res = dr if resolution is None else float(resolution)
    if res <= 0:
        raise ValueError(f"resolution = {resolution!r}; allowed > 0 m")
    h = np.nan_to_num(wf.altitude, nan=0.0)
    gmax = float(ranges[-1]) if max_ground_range is None else float(max_ground_range)
    x = (np.arange(int(np.floor(gmax / res))) + 0.5) * res
    r = np.sqrt(x[None, :] ** 2 + h[:, None] ** 2)
    col = (r - r0) / dr - 0.5  # fractional sample index near→far
    P = wf.intensity.shape[0]
    rows = np.broadcast_to(np.arange(P)[:, None], col.shape)
    stbd = wf.intensity[:, S:].astype(np.float64)
    port = wf.intensity[:, :S][:, ::-1].astype(np.float64)
    kw = dict(order=1, mode="constant", cval=0.0)
    gs = ndimage.map_coordinates(stbd, [rows, col], **kw)
    gp = ndimage.map_coordinates(port, [rows, col], **kw)
    G = x.size
    image = np.concatenate([gp[:, ::-1], gs], axis=1).astype(np.float32)
    gr = np.concatenate([x[::-1], x])
    side = np.concatenate([np.full(G, "port"), np.full(G, "starboard")])
    return GroundRangeImage(image, gr, side)


@dataclass(frozen=True)
class Mosaic:
    """North-up georeferenced grid: image (H, W) float32 mean intensity (0 where empty),
    count (H, W) int32 samples per cell; cell (i, j) centre at x = x_min + (j + ½)·res,
    y = y_max − (i + ½)·res (world m, x east, y north)."""

    image: np.ndarray
    count: np.ndarray
    x_min: float
    y_max: float
    resolution: float

    def cell_center(self, i: np.ndarray, j: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self.x_min + (np.asarray(j) + 0.5) * self.resolution, self.y_max - (
            np.asarray(i) + 0.5
        ) * self.resolution


def sample_ground_positions(wf: SideScanWaterfall) -> np.ndarray:
    """World xy (P, 2S, 2) of every sample on a flat seabed at the ping's altitude below the
    transducer (NaN in the water column): transducer xy ± ground range along the sensor's
    horizontal port axis."""
    S = wf.samples_per_side
    g = ground_range(wf.slant_range[None, :], wf.altitude[:, None])  # (P, 2S)
    sign = np.concatenate([np.ones(S), -np.ones(S)])
    u = wf.sensor_rotation[:, :2, 1]  # port axis xy
    u = u / np.maximum(np.linalg.norm(u, axis=1, keepdims=True), 1e-12)
    base = np.concatenate(
        [
            np.repeat(wf.sensor_position[:, :1, :2], S, 1),
            np.repeat(wf.sensor_position[:, 1:, :2], S, 1),
        ],
        axis=1,
    )
    return base + (g * sign[None, :])[..., None] * u[:, None, :]


def mosaic(
    wf: SideScanWaterfall,
    resolution: float = 0.1,
    bounds: tuple[float, float, float, float] | None = None,
    fill_radius: int = 6,
) -> Mosaic:
    """Georeference all samples (``sample_ground_positions``) into a north-up grid of cell
    size ``resolution`` m, mean intensity per cell (``np.bincount``). bounds: (x_min,
    y_min, x_max, y_max) world m; default: the samples' extent. Empty cells within
    ``fill_radius`` cells of a filled one take the nearest filled value (near nadir the
    samples' ground spacing exceeds the cell size); ``count`` stays 0 there."""
    if resolution <= 0:
        raise ValueError(f"resolution = {resolution!r}; allowed > 0 m")
    xy = sample_ground_positions(wf).reshape(-1, 2)
    v = wf.intensity.reshape(-1).astype(np.float64)
    ok = np.all(np.isfinite(xy), axis=1)
    xy, v = xy[ok], v[ok]
    if bounds is None:
        x0, y0 = xy.min(axis=0)
        x1, y1 = xy.max(axis=0)
    else:
        x0, y0, x1, y1 = bounds
    W = max(1, int(np.ceil((x1 - x0) / resolution)))
    H = max(1, int(np.ceil((y1 - y0) / resolution)))
    j = np.floor((xy[:, 0] - x0) / resolution).astype(np.int64)
    i = np.floor((y1 - xy[:, 1]) / resolution).astype(np.int64)
    inside = (i >= 0) & (i < H) & (j >= 0) & (j < W)
    cell = i[inside] * W + j[inside]
    s = np.bincount(cell, v[inside], minlength=H * W)
    n = np.bincount(cell, minlength=H * W)
    img = np.where(n > 0, s / np.maximum(n, 1), 0.0).reshape(H, W)
    empty = (n == 0).reshape(H, W)
    if fill_radius > 0 and empty.any() and not empty.all():
        dist, (ii, jj) = ndimage.distance_transform_edt(empty, return_indices=True)
        fill = empty & (dist <= fill_radius)
        img[fill] = img[ii[fill], jj[fill]]
    img = img.astype(np.float32)
    return Mosaic(img, n.reshape(H, W).astype(np.int32), float(x0), float(y1), float(resolution))

"""Slant-range correction and a georeferenced mosaic of a side-scan recording.

Slant-range correction (flat seabed): a sample at slant range r from a sonar at altitude h
lies at ground range g = √(r² − h²); samples with r < h are the water column and are
dropped, and so are the zeros readers pad shorter pings with at far range. The corrected
waterfall is resampled onto ground-range bins of ``ground_res_m``
by linear interpolation in slant range (one vectorized ``map_coordinates`` call).

Mosaic: every ground-range bin of every ping is placed in a projected frame (metres east,
north; e.g. local UTM) from the ping's position and heading — starboard lies at heading
+ 90°, port at heading − 90° — and the values falling in each cell of a ``cell_m`` grid
are averaged. Cells no ping reached but with a filled neighbour (pings further apart than
a cell) take the 3 × 3 neighbourhood mean; the others stay nan (GeoTIFF nodata).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import map_coordinates, uniform_filter

from slam.io.waterfall import Waterfall

#: Refuse a mosaic grid larger than this many cells (float32 + counts ≈ 12 B per cell).
MAX_MOSAIC_CELLS = 60_000_000
#: Pings placed per step: the per-step scratch is CHUNK_PINGS × 2G samples × ~40 B.
CHUNK_PINGS = 1024


@dataclass(frozen=True)
class GroundRangeImage:
    """Slant-range-corrected waterfall.

    image : (P, 2G) float32, port far range at column 0, nadir at the centre, nan where
        there is no sample (water column, beyond the last sample, or no altitude).
    ground_res_m : size of one ground-range bin, m.
    """

    image: np.ndarray
    ground_res_m: float

    @property
    def bins_per_side(self) -> int:
        return self.image.shape[1] // 2


def slant_range_correct(
    wf: Waterfall, altitude_m: np.ndarray, ground_res_m: float | None = None
) -> GroundRangeImage:
    """Ground-range image of ``wf`` for per-ping ``altitude_m`` (P,), see module docstring.

    ``ground_res_m`` defaults to the median slant sample spacing. Pings whose altitude is
    nan give an all-nan row.
    """
    h = np.asarray(altitude_m, dtype=np.float64).reshape(-1)
    if h.shape != (wf.n_pings,):
        raise ValueError(f"altitude_m must have shape ({wf.n_pings},), got {h.shape}")
    dr = wf.sample_spacing_m()
    if not np.all(np.isfinite(dr) & (dr > 0)):
        raise ValueError("slant-range correction needs every ping's slant range (file metadata)")
    res = float(np.median(dr)) if ground_res_m is None else float(ground_res_m)
    if not (np.isfinite(res) and res > 0):
        raise ValueError(f"ground_res_m must be > 0, got {ground_res_m}")
    s = wf.samples_per_side
    r_max = dr * s
    g_max = np.sqrt(np.maximum(r_max**2 - np.nan_to_num(h, nan=np.inf) ** 2, 0.0))
    n_bins = max(1, int(np.ceil(np.nanmax(np.where(np.isfinite(h), g_max, 0.0)) / res)))
    g = (np.arange(n_bins) + 0.5) * res
    r = np.sqrt(g[None, :] ** 2 + h[:, None] ** 2)
    col = r / dr[:, None] - 0.5  # fractional sample index (sample k covers [k, k+1)·dr)
    rows = np.broadcast_to(np.arange(wf.n_pings)[:, None], col.shape)
    inside = np.isfinite(col) & (col <= s - 1)
    col = np.where(inside, np.clip(col, 0, s - 1), 0)
    out = []
    for side in (wf.port, wf.starboard):  # near range first
        # trailing zeros are the readers' far-range padding of shorter pings: no data
        last = s - 1 - np.argmax(side[:, ::-1] != 0, axis=1)
        valid = inside & (col <= last[:, None])
        v = map_coordinates(side, [rows, col], order=1, mode="nearest").astype(np.float32)
        out.append(np.where(valid, v, np.nan).astype(np.float32))
    image = np.concatenate([out[0][:, ::-1], out[1]], axis=1)
    return GroundRangeImage(image=image, ground_res_m=res)


@dataclass(frozen=True)
class Mosaic:
    """A north-up grid of averaged intensity.

    image : (H, W) float32, row 0 = north edge, nan = no data.
    west_m, north_m : projected coordinates of the grid's north-west corner, m.
    cell_m : cell size, m.
    crs : the projected frame's CRS string (e.g. ``"EPSG:32612"``), '' when local.
    """

    image: np.ndarray
    west_m: float
    north_m: float
    cell_m: float
    crs: str = ""


def ping_positions_smoothed(t_s: np.ndarray, east: np.ndarray, north: np.ndarray):
    """Positions of GPS fixes repeated over several pings (a 1–5 Hz GPS under a 20 Hz
    sonar) interpolated in time between the pings where the fix changed."""
    t = np.asarray(t_s, dtype=np.float64)
    e, n = np.asarray(east, dtype=np.float64), np.asarray(north, dtype=np.float64)
    fix = np.isfinite(e) & np.isfinite(n)
    change = fix.copy()
    prev = np.maximum.accumulate(np.where(fix, np.arange(e.size), 0))  # last fix at or before
    change[1:] &= (e[1:] != e[prev[:-1]]) | (n[1:] != n[prev[:-1]]) | ~fix[prev[:-1]]
    if change.sum() < 2 or not np.all(np.isfinite(t)):
        return e, n
    k = np.flatnonzero(change)
    es, ns = np.interp(t, t[k], e[k]), np.interp(t, t[k], n[k])
    return np.where(fix, es, np.nan), np.where(fix, ns, np.nan)


def grid_mosaic(
    ground: GroundRangeImage,
    east_m: np.ndarray,
    north_m: np.ndarray,
    heading_deg: np.ndarray,
    cell_m: float,
    crs: str = "",
) -> Mosaic:
    """Average the ground-range image into a north-up grid (see module docstring).

    east_m, north_m, heading_deg : (P,) ping position (projected, m) and heading (deg
    clockwise from north). Rows with a non-finite position or heading are skipped.
    """
    if not (np.isfinite(cell_m) and cell_m > 0):
        raise ValueError(f"mosaic cell size must be > 0 m, got {cell_m}")
    img = ground.image
    p = img.shape[0]
    g = ground.bins_per_side
    e0, n0, hd = (np.asarray(a, dtype=np.float64).reshape(-1) for a in (east_m, north_m, heading_deg))
    if not (e0.size == n0.size == hd.size == p):
        raise ValueError(f"mosaic: positions and headings need {p} values each")
    ok_row = np.isfinite(e0) & np.isfinite(n0) & np.isfinite(hd)
    if not ok_row.any():
        raise ValueError("mosaic: no ping carries a position and heading")
    # signed across-track distance of each column: port negative, starboard positive
    across = np.concatenate([-(np.arange(g)[::-1] + 0.5), np.arange(g) + 0.5]) * ground.ground_res_m
    th = np.radians(hd)
    ex, ny = np.cos(th), -np.sin(th)  # starboard unit vector (east, north)
    reach = np.abs(across).max()
    rows_ok = np.flatnonzero(ok_row)
    west = np.floor((e0[rows_ok].min() - reach) / cell_m) * cell_m
    east = np.ceil((e0[rows_ok].max() + reach) / cell_m) * cell_m
    south = np.floor((n0[rows_ok].min() - reach) / cell_m) * cell_m
    north = np.ceil((n0[rows_ok].max() + reach) / cell_m) * cell_m
    width = max(1, round((east - west) / cell_m))
    height = max(1, round((north - south) / cell_m))
    if width * height > MAX_MOSAIC_CELLS:
        raise ValueError(
            f"mosaic of {width} x {height} cells at {cell_m} m exceeds the bound of "
            f"{MAX_MOSAIC_CELLS} cells (~{MAX_MOSAIC_CELLS * 12 // 2**20} MiB); use a larger cell"
        )
    total = np.zeros(width * height)
    count = np.zeros(width * height)
    for i0 in range(0, rows_ok.size, CHUNK_PINGS):  # bounded memory: CHUNK_PINGS rows at once
        r = rows_ok[i0 : i0 + CHUNK_PINGS]
        v = img[r].astype(np.float64)
        ok = np.isfinite(v)
        xe = (e0[r, None] + across[None, :] * ex[r, None])[ok]
        yn = (n0[r, None] + across[None, :] * ny[r, None])[ok]
        col = np.clip(((xe - west) / cell_m).astype(np.int64), 0, width - 1)
        row = np.clip(((north - yn) / cell_m).astype(np.int64), 0, height - 1)
        flat = row * width + col
        total += np.bincount(flat, weights=v[ok], minlength=width * height)
        count += np.bincount(flat, minlength=width * height)
    total, count = total.reshape(height, width), count.reshape(height, width)
    if not count.any():
        raise ValueError("mosaic: no sample has both a position and a ground range")
    mean = np.full((height, width), np.nan, dtype=np.float32)
    hit = count > 0
    mean[hit] = (total[hit] / count[hit]).astype(np.float32)
    s3 = uniform_filter(np.where(hit, mean, 0.0).astype(np.float64), size=3, mode="constant")
    c3 = uniform_filter(hit.astype(np.float64), size=3, mode="constant")
    fill = ~hit & (c3 > 0.5 / 9)  # at least one of the 9 (guards round-off of the running sum)
    mean[fill] = (s3[fill] / c3[fill]).astype(np.float32)
    # crop the conservative bounding box to the cells holding data
    rows = np.flatnonzero(np.isfinite(mean).any(axis=1))
    cols = np.flatnonzero(np.isfinite(mean).any(axis=0))
    mean = mean[rows[0] : rows[-1] + 1, cols[0] : cols[-1] + 1]
    return Mosaic(image=np.ascontiguousarray(mean), west_m=float(west + cols[0] * cell_m),
                  north_m=float(north - rows[0] * cell_m), cell_m=float(cell_m), crs=crs)

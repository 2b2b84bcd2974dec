"""Objects cut by the edge of a tile.

A tile cut out of a longer side-scan record cuts the objects lying across its edges: a
cut object is a normal object seen partly. Two steps of the detection chain treat such
an object differently from a whole one, and :mod:`.detector` can handle both explicitly
(``DetectorConfig.frame_padding`` and ``DetectorConfig.reflect_px``):

* **Zero padding.** A tile that reaches past the end of a swath is padded with rows or
  columns of zeros. The no-echo rule (:func:`.artefacts.no_echo_mask`) reads that padding
  as a water column and drops every region touching it, so an object cut by the end of
  the data is dropped as an edge artefact. :func:`data_frame` finds the tile's data
  frame (the rows and columns between the outermost ones that hold any echo); judged
  inside that frame the padding is outside the image, like the tile edge itself, and
  no-echo areas inside the data (a water column) still count.
* **Algorithm 2 at the edge.** Hole filling only fills background that cannot be
  reached from outside the image, so a ring or a "C" open towards the tile edge keeps
  its hole; small-component removal drops a cut part with fewer than ``a`` pixels even
  when the whole object is large. :func:`algorithm2_reflected` runs Algorithm 2 on the
  thresholded image extended by reflection across the tile edges and keeps the part
  inside the tile: a cut object is completed by its mirror image while it is filtered,
  and an object far from the edges is treated exactly as before.

Coordinates: pixel (row, col), origin at the tile's top-left pixel.
"""

from __future__ import annotations

import warnings
from dataclasses import replace

import cv2
import numpy as np

from .image import as_gray8
from .otsu import otsu_threshold_hist
from .regions import Region, extract_regions, morphology_chain

__all__ = [
    "algorithm2_reflected",
    "bright_edge_strips",
    "data_frame",
    "seabed_histogram_mask",
    "shift_regions",
    "touches_edge",
]


def data_frame(gray8: np.ndarray, level: int = 2) -> tuple[slice, slice]:
    """``(rows, cols)`` slices of the tile's data frame: the rows and columns from the
    first to the last one holding a pixel above ``level`` (zero padding at the tile's
    edges is outside). A tile with no such pixel keeps its whole extent."""
    if not 0 <= int(level) < 255:
        raise ValueError(f"level={level!r}: must be an integer grey level in [0, 255)")
    g = as_gray8(gray8)
    echo = g > level
    rows = np.flatnonzero(echo.any(axis=1))
    if rows.size == 0:
        return slice(0, g.shape[0]), slice(0, g.shape[1])
    cols = np.flatnonzero(echo.any(axis=0))
    return slice(int(rows[0]), int(rows[-1]) + 1), slice(int(cols[0]), int(cols[-1]) + 1)


def algorithm2_reflected(
    binary: np.ndarray, a_px: int, dilate_iterations: int, pad_px: int
) -> tuple[tuple[Region, ...], np.ndarray]:
    """Algorithm 2 (:func:`.regions.morphology_chain`, :func:`.regions.extract_regions`)
    on ``binary`` (H, W) extended by ``pad_px`` pixels of reflection (``BORDER_REFLECT_101``:
    the edge pixel is the mirror line; reflected again where ``pad_px`` exceeds a side)
    on every side, cropped back to (H, W). Returns
    ``(regions, int32 labels)`` of the cropped mask. ``pad_px = 0`` is Algorithm 2 itself."""
    if int(pad_px) != pad_px or pad_px < 0:
        raise ValueError(f"reflect_px={pad_px!r}: must be an integer >= 0 (pixels)")
    b = np.ascontiguousarray(np.asarray(binary)).astype(np.uint8, copy=False)
    if b.ndim != 2:
        raise ValueError(f"binary: shape {b.shape} is not 2-D")
    h, w = b.shape
    p = int(pad_px)
    if p:
        b = cv2.copyMakeBorder(b, p, p, p, p, cv2.BORDER_REFLECT_101)
    m = morphology_chain(b, a_px, dilate_iterations)
    if p:
        m = np.ascontiguousarray(m[p : p + h, p : p + w])
    return extract_regions(m)


def shift_regions(regions: tuple[Region, ...], dr: int, dc: int) -> tuple[Region, ...]:
    """The regions moved by ``dr`` rows and ``dc`` columns (centroid and bounding box;
    from a crop's coordinates to the tile's)."""
    if dr == 0 and dc == 0:
        return tuple(regions)
    return tuple(
        replace(
            r,
            centroid_rc=(r.centroid_rc[0] + dr, r.centroid_rc[1] + dc),
            bbox=(r.bbox[0] + dr, r.bbox[1] + dc, r.bbox[2] + dr, r.bbox[3] + dc),
        )
        for r in regions
    )


def touches_edge(regions: tuple[Region, ...], shape: tuple[int, int]) -> np.ndarray:
    """``(n,)`` bool: regions whose bounding box reaches the first or last row or column
    of an image of ``shape`` (cut by the edge)."""
    h, w = shape
    return np.array(
        [r.bbox[0] == 0 or r.bbox[1] == 0 or r.bbox[2] == h or r.bbox[3] == w for r in regions],
        dtype=bool,
    )


def _edge_run(flags: np.ndarray, limit: int) -> tuple[int, int]:
    """Lengths of the runs of True at the start and at the end of ``flags``; a run longer
    than ``limit`` counts as 0 (it is the tile's seabed, not a strip at its edge)."""
    n = flags.size
    head = n if flags.all() else int(np.argmin(flags))
    tail = n if flags.all() else int(np.argmin(flags[::-1]))
    return (head if head <= limit else 0), (tail if tail <= limit else 0)


def _medians_above(g: np.ndarray, valid: np.ndarray, axis: int, level: float) -> np.ndarray:
    """Per row (``axis=1``) or column (``axis=0``): median of the valid pixels > level."""
    if valid.all():
        return np.median(g, axis=axis) > level
    x = np.where(valid, g.astype(np.float32), np.nan)
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN lines: not bright
        return np.nanmedian(x, axis=axis) > level


def bright_edge_strips(
    gray8: np.ndarray, valid: np.ndarray, level: float, columns: bool = True
) -> np.ndarray:
    """``(H, W)`` bool: bright strips along the tile edges — the runs of rows (and, with
    ``columns``, of columns) starting at a tile edge whose median grey level over the
    ``valid`` pixels is above ``level``, each at most half the tile. In a waterfall tile
    (rows = pings, columns = range) a row strip is a band of pings brighter over the
    whole swath (a gain or display step at the tile's start or end), a column strip a
    near-range band. Rows/columns with no valid pixel are not bright."""
    g = as_gray8(gray8)
    v = np.asarray(valid, dtype=bool)
    if v.shape != g.shape:
        raise ValueError(f"valid: shape {v.shape}, need the image's {g.shape}")
    h, w = g.shape
    out = np.zeros((h, w), bool)
    top, bottom = _edge_run(_medians_above(g, v, 1, level), h // 2)
    left, right = _edge_run(_medians_above(g, v, 0, level), w // 2) if columns else (0, 0)
    out[:top] = True
    out[h - bottom :] = True
    out[:, :left] = True
    out[:, w - right :] = True
    return out


def seabed_histogram_mask(
    gray8: np.ndarray,
    no_echo: np.ndarray,
    strips: str = "both",
    drop_no_echo: bool = True,
) -> np.ndarray:
    """``(H, W)`` bool: the pixels a tile's threshold is computed from — the tile without
    its no-echo areas (``no_echo``, :func:`.artefacts.no_echo_mask`; kept with
    ``drop_no_echo=False``) and without its bright edge strips (:func:`bright_edge_strips`
    at the Otsu level of the pixels outside no-echo areas; ``strips``: ``"both"`` rows
    and columns, ``"rows"`` ping bands only, ``"none"``). Where that leaves nothing, the
    tile without no-echo; where that is empty too, every pixel."""
    if strips not in ("both", "rows", "none"):
        raise ValueError(f"strips={strips!r}: allowed both, rows, none")
    g = as_gray8(gray8)
    ne = np.asarray(no_echo, dtype=bool)
    if ne.shape != g.shape:
        raise ValueError(f"no_echo: shape {ne.shape}, need the image's {g.shape}")
    valid = ~ne
    if not valid.any():
        return np.ones(g.shape, bool)
    if strips == "none":
        return valid
    level, _ = otsu_threshold_hist(np.bincount(g[valid], minlength=256))
    band = bright_edge_strips(g, valid, level, columns=strips == "both")
    keep = (valid if drop_no_echo else np.ones(g.shape, bool)) & ~band
    return keep if keep.any() else valid

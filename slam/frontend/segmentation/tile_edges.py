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

from dataclasses import replace

import cv2
import numpy as np

from .image import as_gray8
from .regions import Region, extract_regions, morphology_chain

__all__ = [
    "algorithm2_reflected",
    "data_frame",
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

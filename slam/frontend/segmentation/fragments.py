"""Merging the fragments of one object into one detection.

A thresholded side-scan object often breaks into several regions (a highlight cut by
speckle or by its own shadow); scored one by one, each fragment inside the object's mask
would count as a separate true positive, and as landmarks they would be separate
landmarks. :func:`merge_fragments` groups the regions whose pixels come within
``gap_px`` of each other (8-connected components of the foreground dilated by a
``(gap_px + 1) × (gap_px + 1)`` square, i.e. gaps of at most ``gap_px`` pixels along rows
or columns are bridged) and describes each group as one region: its area is the number of
fragment pixels (gap pixels are not counted), its centroid their mean, its bounding box
the union, its axes from their second moments.
"""

from __future__ import annotations

import cv2
import numpy as np
from scipy.ndimage import find_objects

from .regions import Region, cc_stats

__all__ = ["merge_fragments", "regions_from_labels"]


def regions_from_labels(labels: np.ndarray) -> tuple[Region, ...]:
    """Regions of an int label image with consecutive labels 1..n (0 = background):
    area, centroid, bounding box and second-moment axes as
    :func:`.regions.extract_regions` computes them."""
    lab_img = np.asarray(labels)
    if lab_img.ndim != 2:
        raise ValueError(f"labels: shape {lab_img.shape} is not 2-D")
    n = int(lab_img.max(initial=0)) + 1
    if n <= 1:
        return ()
    flat = np.flatnonzero(lab_img)
    lab = lab_img.ravel()[flat]
    rows, cols = np.divmod(flat, lab_img.shape[1])
    area = np.bincount(lab, minlength=n).astype(np.float64)
    area_div = np.maximum(area, 1.0)
    cx = np.bincount(lab, weights=cols, minlength=n) / area_div
    cy = np.bincount(lab, weights=rows, minlength=n) / area_div
    dx = cols - cx[lab]
    dy = rows - cy[lab]
    sxx = np.bincount(lab, weights=dx * dx, minlength=n) / area_div
    syy = np.bincount(lab, weights=dy * dy, minlength=n) / area_div
    sxy = np.bincount(lab, weights=dx * dy, minlength=n) / area_div
    half_tr = 0.5 * (sxx + syy)
    disc = np.sqrt(np.maximum(0.25 * (sxx - syy) ** 2 + sxy**2, 0.0))
    major = 4.0 * np.sqrt(half_tr + disc)
    minor = 4.0 * np.sqrt(np.maximum(half_tr - disc, 0.0))
    boxes = find_objects(lab_img.astype(np.int32, copy=False), max_label=n - 1)
    out = []
    for k in range(1, n):
        sl = boxes[k - 1]
        if sl is None or area[k] == 0:
            continue
        out.append(
            Region(
                label=k,
                area_px=int(area[k]),
                centroid_rc=(float(cy[k]), float(cx[k])),
                bbox=(sl[0].start, sl[1].start, sl[0].stop, sl[1].stop),
                major_axis_px=float(major[k]),
                minor_axis_px=float(minor[k]),
            )
        )
    return tuple(out)


def merge_fragments(
    labels: np.ndarray, gap_px: int, keep: np.ndarray | None = None
) -> tuple[tuple[Region, ...], np.ndarray]:
    """Group the regions of ``labels`` whose pixels are at most ``gap_px`` apart (module
    docstring). ``keep`` (bool per label, index 0 unused) restricts the merge to some
    regions (the others are dropped first). Returns ``(regions, merged int32 labels)``.
    ``gap_px = 0`` only relabels."""
    if int(gap_px) != gap_px or gap_px < 0:
        raise ValueError(f"gap_px={gap_px!r}: must be an integer >= 0 (pixels)")
    lab = np.asarray(labels, dtype=np.int32)
    if keep is not None:
        lab = np.where(np.asarray(keep, bool)[lab], lab, 0).astype(np.int32)
    fg = (lab > 0).view(np.uint8) if lab.dtype == np.bool_ else (lab > 0).astype(np.uint8)
    if gap_px > 0:
        k = np.ones((gap_px + 1, gap_px + 1), np.uint8)
        grown = cv2.dilate(fg, k, anchor=(gap_px // 2, gap_px // 2))
    else:
        grown = fg
    _n, groups, _stats, _c = cc_stats(grown)
    merged = np.where(fg > 0, groups, 0).astype(np.int32)
    # consecutive labels over the groups that hold fragment pixels
    present = np.zeros(int(merged.max(initial=0)) + 1, bool)
    present[np.unique(merged)] = True
    present[0] = False
    new_id = np.zeros(present.size, np.int32)
    new_id[present] = np.arange(1, int(present.sum()) + 1, dtype=np.int32)
    merged = new_id[merged]
    return regions_from_labels(merged), merged

"""Compiled passes of the improved Otsu front end: Canny's non-maximum suppression,
hysteresis and the count N_a of small edge objects in one kernel, the removal of small
8-connected components (Algorithm 2 step 1), the hole filling (step 4) and the regions'
second-moment sums.

:func:`small_edge_objects` computes from the float32 gradients what
``count_small_contours(cv2.Canny(rint(dx·s), rint(dy·s), …), a)`` computes in
:mod:`.methods`, without the int16 gradient images, the edge image and the component
label image OpenCV needs one pass each for:

* the int16 gradients are ``rint(dx · scale)`` in float64, saturated (the rounding of
  ``cv2.multiply(dx, scale, dtype=cv2.CV_16S)``), with ``scale`` = full scale / the
  maximum of ``cv2.magnitude(dx, dy)``;
* Canny with the L2 norm is OpenCV's ``canny.cpp`` in integers: squared magnitude
  ``dx² + dy²``, thresholds ``floor(min(t, 32767)²)``, the direction sectors from
  tan 22.5° = 13573 / 2¹⁵, strict comparison with the neighbour before and non-strict
  with the one after (strict both ways on the diagonals), zero magnitude outside the
  image; hysteresis grows the edges from the pixels above the high threshold through
  8-connected candidates;
* N_a is the number of 8-connected objects of that edge map with fewer than ``a``
  pixels (what ``cv2.connectedComponentsWithStats`` counts).

Tests (tests/slam/frontend/test_seg_kernels.py) compare both functions with the OpenCV
implementations on random masks of every density and sizes, and on synthetic and real
sonar images. Compiled by numba on first use and cached on disk (``cache=True``).
"""

from __future__ import annotations

import math

import cv2
import numba
import numpy as np

__all__ = [
    "canny_thresholds",
    "fill_holes_u8",
    "remove_small_components_u8",
    "second_moment_sums",
    "small_edge_objects",
]

#: int16 full scale of the gradients handed to Canny (as :mod:`.methods`)
GRAD_SCALE = 16000.0
#: OpenCV canny.cpp: tan(22.5°) in Q15
_TG22 = 13573


#: adding and subtracting 1.5·2⁵² rounds a float64 below 2⁵¹ to an integer, half to even
_RINT_MAGIC = 6755399441055744.0


@numba.njit(cache=True)
def _scale_row(dxr, dyr, scale, xr, yr, mr):
    """One row of :func:`_scaled_gradients` (straight-line code, vectorized by LLVM)."""
    for j in range(dxr.size):
        va = np.float64(dxr[j]) * scale
        vb = np.float64(dyr[j]) * scale
        va = -32768.0 if va < -32768.0 else (32767.0 if va > 32767.0 else va)
        vb = -32768.0 if vb < -32768.0 else (32767.0 if vb > 32767.0 else vb)
        a = np.int32((va + _RINT_MAGIC) - _RINT_MAGIC)
        b = np.int32((vb + _RINT_MAGIC) - _RINT_MAGIC)
        xr[j] = np.int16(a)
        yr[j] = np.int16(b)
        mr[j + 1] = a * a + b * b


@numba.njit(cache=True)
def _scaled_gradients(dx, dy, scale):
    """int16 ``rint(dx · scale)``, ``rint(dy · scale)`` (float64, saturated: the
    rounding of ``cv2.multiply(dx, scale, dtype=cv2.CV_16S)``) and their squared
    magnitude in a zero-bordered flat (H + 2)(W + 2) int32 array."""
    h, w = dx.shape
    wp = w + 2
    xs = np.empty((h, w), np.int16)
    ys = np.empty((h, w), np.int16)
    mag = np.zeros((h + 2) * wp, np.int32)
    rows = mag.reshape(h + 2, wp)
    for i in range(h):
        _scale_row(dx[i], dy[i], scale, xs[i], ys[i], rows[i + 1])
    return xs, ys, mag


@numba.njit(cache=True)
def _suppress_row(xr, yr, mp, mc, mn, low, high, out):
    """Non-maximum suppression of one row, branch-free int32 arithmetic (vectorized by
    LLVM): ``mp``, ``mc``, ``mn`` are the zero-bordered magnitude rows above, at and
    below (pixel j at index j + 1); ``out`` gets 0 (not an edge), 1 (candidate: local
    maximum along the gradient sector above ``low``) or 2 (also above ``high``)."""
    for j in range(xr.size):
        m = mc[j + 1]
        xv = np.int32(xr[j])
        yv0 = np.int32(yr[j])
        x = np.abs(xv)
        yv = np.abs(yv0) << np.int32(15)
        tg22x = x * np.int32(_TG22)
        tg67x = tg22x + (x << np.int32(16))
        horiz = np.int32(yv < tg22x)
        vert = np.int32(yv > tg67x) * (1 - horiz)
        diag = 1 - horiz - vert
        pos = np.int32((xv ^ yv0) >= 0)  # diagonal direction s = +1
        k_h = np.int32(m > mc[j]) & np.int32(m >= mc[j + 2])
        k_v = np.int32(m > mp[j + 1]) & np.int32(m >= mn[j + 1])
        k_d1 = np.int32(m > mp[j]) & np.int32(m > mn[j + 2])
        k_d2 = np.int32(m > mp[j + 2]) & np.int32(m > mn[j])
        k_d = pos * k_d1 + (1 - pos) * k_d2
        keep = (horiz * k_h + vert * k_v + diag * k_d) & np.int32(m > low)
        out[j] = np.uint8(keep * (1 + np.int32(m > high)))


@numba.njit(cache=True)
def _suppress(xs, ys, mag, low, high):
    """Non-maximum suppression of the image: flat, zero-bordered uint8 map of
    :func:`_suppress_row` values (OpenCV's sectors: tan 22.5° = 13573 / 2¹⁵, strict
    comparison before, non-strict after, strict both ways on the diagonals)."""
    h, w = xs.shape
    wp = w + 2
    emap = np.zeros((h + 2) * wp, np.uint8)
    rows = mag.reshape(h + 2, wp)
    low32 = np.int32(min(low, 2**31 - 1))
    high32 = np.int32(min(high, 2**31 - 1))
    for i in range(h):
        start = (i + 1) * wp + 1
        _suppress_row(
            xs[i], ys[i], rows[i], rows[i + 1], rows[i + 2], low32, high32, emap[start : start + w]
        )
    return emap


@numba.njit(cache=True)
def _canny_small_objects(dx, dy, scale, low, high, a_px):
    """OpenCV's Canny (L2) on the scaled gradients with squared integer thresholds
    ``low``, ``high``; returns the number of 8-connected edge objects with fewer than
    ``a_px`` pixels.

    Hysteresis and counting in one pass: an 8-connected component of candidate and
    strong pixels is entirely edge when it holds a strong pixel (hysteresis grows
    through candidates only), and is then one edge object; so the components are grown
    from the strong pixels and counted by size. (Flat indices fit int32 below 2³¹
    pixels.)"""
    w = dx.shape[1]
    wp = w + 2
    xs, ys, mag = _scaled_gradients(dx, dy, scale)
    emap = _suppress(xs, ys, mag, low, high)
    offs = np.array([-wp - 1, -wp, -wp + 1, -1, 1, wp - 1, wp, wp + 1], np.int32)
    stack = np.empty(emap.size, np.int32)  # each pixel is pushed at most once
    n_small = 0
    for p0 in range(emap.size):
        if emap[p0] != 2:  # components are grown from their strong pixels only
            continue
        emap[p0] = 0
        stack[0] = p0
        top = 1
        size = 0
        while top > 0:
            top -= 1
            p = stack[top]
            size += 1
            for off in offs:
                q = p + off
                if emap[q] != 0:
                    emap[q] = 0
                    stack[top] = q
                    top += 1
        if size < a_px:
            n_small += 1
    return n_small


def canny_thresholds(high: float, low_ratio: float) -> tuple[int, int]:
    """OpenCV's integer thresholds of an L2 Canny on gradients of full scale
    :data:`GRAD_SCALE`: ``floor(min(t, 32767)²)`` of the low and high thresholds."""
    lo = low_ratio * high * GRAD_SCALE
    hi = high * GRAD_SCALE
    if lo > hi:
        lo, hi = hi, lo
    lo = min(32767.0, lo)
    hi = min(32767.0, hi)
    if lo > 0:
        lo *= lo
    if hi > 0:
        hi *= hi
    return math.floor(lo), math.floor(hi)


def small_edge_objects(
    dx: np.ndarray, dy: np.ndarray, high: float, low_ratio: float, a_px: int
) -> int:
    """N_a from the float32 gradients ``dx``, ``dy`` (H, W) of the smoothed image: the
    number of 8-connected objects of their Canny edge map (thresholds ``high`` and
    ``low_ratio · high`` of the maximum magnitude, MATLAB's convention) with fewer than
    ``a_px`` pixels."""
    mmax = cv2.minMaxLoc(cv2.magnitude(dx, dy))[1]
    if mmax <= 0.0:
        return 0
    low, hi = canny_thresholds(high, low_ratio)
    return int(_canny_small_objects(dx, dy, GRAD_SCALE / mmax, low, hi, int(a_px)))


@numba.njit(cache=True)
def _remove_small(m, a_px):
    """Copy of the 0/1 mask ``m`` without the 8-connected components smaller than
    ``a_px``, and whether any was removed. Breadth-first over a zero-bordered copy."""
    h, w = m.shape
    wp = w + 2
    pad = np.zeros((h + 2) * wp, np.uint8)
    for i in range(h):
        base = (i + 1) * wp + 1
        for j in range(w):
            pad[base + j] = m[i, j] != 0
    offs = np.array([-wp - 1, -wp, -wp + 1, -1, 1, wp - 1, wp, wp + 1], np.int32)
    queue = np.empty(pad.size, np.int32)  # each pixel is queued once
    removed = False
    for p0 in range(pad.size):
        if pad[p0] != 1:
            continue
        pad[p0] = 2
        queue[0] = p0
        n = 1
        head = 0
        while head < n:
            p = queue[head]
            head += 1
            for off in offs:
                q = p + off
                if pad[q] == 1:
                    pad[q] = 2
                    queue[n] = q
                    n += 1
        if n < a_px:
            removed = True
            for t in range(n):
                pad[queue[t]] = 0
    out = np.empty((h, w), np.uint8)
    for i in range(h):
        base = (i + 1) * wp + 1
        for j in range(w):
            out[i, j] = pad[base + j] != 0
    return out, removed


def remove_small_components_u8(m: np.ndarray, a_px: int) -> np.ndarray:
    """A 0/1 ``uint8`` mask without its 8-connected components of fewer than ``a_px``
    pixels (``m`` itself when none is removed)."""
    out, removed = _remove_small(m, int(a_px))
    return out if removed else m


@numba.njit(cache=True)
def _add_moments(sums, k, i, j, cx, cy):
    dx = j - cx[k]
    dy = i - cy[k]
    sums[0, k] += dx * dx
    sums[1, k] += dy * dy
    sums[2, k] += dx * dy


@numba.njit(cache=True)
def second_moment_sums(labels, cx, cy, n, boxes):
    """Per-label sums of ``dx²``, ``dy²`` and ``dx·dy`` about the centroids ``(cx, cy)``
    (n,) over the pixels of the (H, W) label image (label 0 skipped), each label's pixels
    in raster order: the floats ``np.bincount(labels, weights)`` gives. ``boxes`` (n, 4)
    ``(left, top, width, height)`` (OpenCV's stats): when their areas add up to less than
    the image each label is summed inside its box, else in one pass over the image."""
    h, w = labels.shape
    sums = np.zeros((3, n))
    box_area = 0
    for k in range(1, n):
        box_area += boxes[k, 2] * boxes[k, 3]
    if box_area < h * w:
        for k in range(1, n):
            x0, y0, bw, bh = boxes[k, 0], boxes[k, 1], boxes[k, 2], boxes[k, 3]
            for i in range(y0, y0 + bh):
                for j in range(x0, x0 + bw):
                    if labels[i, j] == k:
                        _add_moments(sums, k, i, j, cx, cy)
    else:
        for i in range(h):
            for j in range(w):
                if labels[i, j] > 0:
                    _add_moments(sums, labels[i, j], i, j, cx, cy)
    return sums[0], sums[1], sums[2]


@numba.njit(cache=True)
def _find(parent, a):
    root = a
    while parent[root] != root:
        root = parent[root]
    while parent[a] != root:
        nxt = parent[a]
        parent[a] = root
        a = nxt
    return root


@numba.njit(cache=True)
def fill_holes_u8(m):
    """``imfill(m, 'holes')`` of a 0/1 uint8 mask: background pixels not reachable from
    outside the image through 4-connected background become 1.

    Run-based: the background runs of each row are joined (union–find) with the runs of
    the row above that share a column; a run set reaches outside when one of its runs
    touches the image border. Work in proportion to the runs, not the pixels."""
    h, w = m.shape
    cap = 1024
    rs = np.empty(cap, np.int64)  # run start column
    re = np.empty(cap, np.int64)  # run end column (exclusive)
    row_first = np.empty(h + 1, np.int64)
    n = 0
    for i in range(h):
        row_first[i] = n
        j = 0
        while j < w:
            if m[i, j] != 0:
                j += 1
                continue
            s = j
            while j < w and m[i, j] == 0:
                j += 1
            if n == cap:
                cap *= 2
                rs2 = np.empty(cap, np.int64)
                re2 = np.empty(cap, np.int64)
                rs2[:n] = rs[:n]
                re2[:n] = re[:n]
                rs = rs2
                re = re2
            rs[n] = s
            re[n] = j
            n += 1
    row_first[h] = n
    parent = np.arange(n + 1)  # n = the outside
    outside = n
    for i in range(h):
        a0, a1 = row_first[i], row_first[i + 1]
        for r in range(a0, a1):
            if i == 0 or i == h - 1 or rs[r] == 0 or re[r] == w:
                ra = _find(parent, r)
                if ra != outside:
                    parent[ra] = outside
        if i == 0:
            continue
        b = row_first[i - 1]
        b1 = a0
        r = a0
        while r < a1 and b < b1:
            if rs[r] < re[b] and rs[b] < re[r]:  # 4-connected: a shared column
                ra = _find(parent, r)
                rb = _find(parent, b)
                if ra != rb:
                    if rb == outside:
                        parent[ra] = rb
                    else:
                        parent[rb] = ra
            if re[r] < re[b]:
                r += 1
            else:
                b += 1
    out = m.copy()
    for i in range(h):
        for r in range(row_first[i], row_first[i + 1]):
            if _find(parent, r) != outside:
                for j in range(rs[r], re[r]):
                    out[i, j] = 1
    return out


@numba.njit(cache=True)
def otsu_from_hist(hist):
    """OpenCV's ``THRESH_OTSU`` threshold (``getThreshVal_Otsu_8u``: float64 class
    moments accumulated level by level, levels whose class weight is within float32 eps
    of 0 or 1 skipped, the first strict maximum of ``q1 q2 (mu1 - mu2)²``) from a (256,)
    histogram of exact counts; equal to ``cv2.threshold(img, 0, 255, THRESH_OTSU)``."""
    n = 0.0
    for i in range(256):
        n += hist[i]
    scale = 1.0 / n
    mu = 0.0
    for i in range(256):
        mu += i * np.float64(hist[i])
    mu *= scale
    mu1 = 0.0
    q1 = 0.0
    max_sigma = 0.0
    max_val = 0
    eps = 1.1920928955078125e-07  # FLT_EPSILON
    for i in range(256):
        p_i = hist[i] * scale
        mu1 *= q1
        q1 += p_i
        q2 = 1.0 - q1
        if min(q1, q2) < eps or max(q1, q2) > 1.0 - eps:
            continue
        mu1 = (mu1 + i * p_i) / q1
        mu2 = (mu - q1 * mu1) / q2
        sigma = q1 * q2 * (mu1 - mu2) * (mu1 - mu2)
        if sigma > max_sigma:
            max_sigma = sigma
            max_val = i
    return max_val

"""Compiled range-cell scatters of echo formation (:mod:`sim.sonar.echo`): from the
per-ray footprints (:mod:`sim.sonar.echo_kernels`) to the (rows, bins) mean intensity,
labels and background hit positions in one call (:func:`image_pass`).

Each step does in one pass what the array version did in a chain of ``np.bincount``,
``np.cumsum``, ``np.sort`` and ``np.interp`` calls, with the same floating-point operations
in the same order (sums accumulated in input order, prefix sums along the row, numpy's
interpolation formula and its special cases), so the results are the same bytes
(tests/sim/sonar/test_sonar_echo.py compares them with tests/helpers/legacy_echo.py).
Compiled by numba on first use and cached on disk (``cache=True``).
"""

from __future__ import annotations

import numba
import numpy as np

from sim.sonar.echo_kernels import F_CENTRE, F_EBG, F_END, F_ENERGY, F_START


@numba.njit(cache=True, error_model="numpy")
def splat_boxes(rows, a, b, e, n_rows, n_bins):
    """Energies ``e`` (N,) spread uniformly over fractional bin spans [a, b) of row
    ``rows`` (N,) int64; returns (n_rows, n_bins) float64, clipped at 0.

    Second-difference array: a kink of slope s at fractional position p = i + f adds
    s(1 − f) at i + 1 and s·f at i + 2; its prefix sum along the row is the cell value.
    """
    stride = n_bins + 3
    n = rows.size
    d2 = np.zeros(n_rows * stride)
    ba = np.empty(n, np.int64)
    bb = np.empty(n, np.int64)
    rho = np.empty(n)
    fa = np.empty(n)
    fb = np.empty(n)
    for i in range(n):
        aa = min(max(a[i], 0.0), float(n_bins))
        ab = min(max(b[i], 0.0), float(n_bins))
        ia = np.floor(aa)
        ib = np.floor(ab)
        fa[i] = aa - ia
        fb[i] = ab - ib
        rho[i] = e[i] / (b[i] - a[i])
        base = rows[i] * stride + 1
        ba[i] = base + np.int64(ia)
        bb[i] = base + np.int64(ib)
    # the four terms in the order np.bincount saw them (all rays' first terms, then …)
    for i in range(n):
        d2[ba[i]] += rho[i] * (1.0 - fa[i])
    for i in range(n):
        d2[ba[i] + 1] += rho[i] * fa[i]
    for i in range(n):
        d2[bb[i]] += -rho[i] * (1.0 - fb[i])
    for i in range(n):
        d2[bb[i] + 1] += -rho[i] * fb[i]
    out = np.empty((n_rows, n_bins))
    for r in range(n_rows):
        s = d2[r * stride]
        for k in range(n_bins):
            s += d2[r * stride + k + 1]
            out[r, k] = s if s >= 0.0 else 0.0
    return out


@numba.njit(cache=True, error_model="numpy")
def label_cells(rows, a, b, bg, lab, n_rows, n_bins):
    """Labels (n_rows, n_bins) int32 of the background footprints: 0 where a seabed
    footprint covers the cell, else −2 where an unlabelled geom's does, else −1; and
    each footprint's integer cell span [start, end) clipped to [0, n_bins]."""
    n = rows.size
    start = np.empty(n, np.int64)
    end = np.empty(n, np.int64)
    stride = n_bins + 1
    c_sb = np.zeros(n_rows * stride, np.int64)
    c_ot = np.zeros(n_rows * stride, np.int64)
    for i in range(n):
        s = np.int64(min(max(np.floor(a[i]), 0.0), float(n_bins)))
        t = np.int64(min(max(np.ceil(b[i]), 0.0), float(n_bins)))
        start[i] = s
        end[i] = t
        if bg[i] and lab[i] == 0:
            c_sb[rows[i] * stride + s] += 1
            c_sb[rows[i] * stride + t] -= 1
        elif bg[i] and lab[i] == -2:
            c_ot[rows[i] * stride + s] += 1
            c_ot[rows[i] * stride + t] -= 1
    labels = np.empty((n_rows, n_bins), np.int32)
    for q in range(n_rows):
        s0 = 0
        s1 = 0
        for k in range(n_bins):
            s0 += c_sb[q * stride + k]
            s1 += c_ot[q * stride + k]
            labels[q, k] = 0 if s0 > 0 else (-2 if s1 > 0 else -1)
    return labels, start, end


@numba.njit(cache=True, error_model="numpy")
def _shaped_boxes(rows, f, k, sub, src):
    """The boxes of the shaped splat: the footprints with one sub-box (k == 1, in ray
    order) followed by the sub-boxes (spans ``sub[0:2]``, exponentiated log-weights
    ``sub[2]``), each sub-box getting its ray's background energy × weight / (sum of the
    ray's weights). Returns rows, starts, ends and energies of all boxes."""
    nn = 0
    for i in range(k.size):
        if k[i] == 1:
            nn += 1
    m = nn + src.size
    rr = np.empty(m, np.int64)
    aa = np.empty(m)
    bb = np.empty(m)
    ee = np.empty(m)
    p = 0
    for i in range(k.size):
        if k[i] == 1:
            rr[p], aa[p], bb[p], ee[p] = rows[i], f[F_START, i], f[F_END, i], f[F_EBG, i]
            p += 1
    q = 0
    while q < src.size:
        ray = src[q]
        s = 0.0
        for j in range(k[ray]):
            s += sub[2, q + j]
        for j in range(k[ray]):
            rr[p], aa[p], bb[p] = rows[ray], sub[0, q + j], sub[1, q + j]
            ee[p] = f[F_EBG, ray] * (sub[2, q + j] / s)
            p += 1
        q += k[ray]
    return rr, aa, bb, ee


@numba.njit(cache=True, error_model="numpy")
def _centre_means(f, lab, rows, r, dirs, n_cells, n_bins, acc):
    """Known cells (ascending) and their energy-weighted mean hit offsets (3, K) from the
    origin: cells row · n_bins + floor(fc) holding background footprint centres, each
    Σ (E + 1e-300)·r·d / Σ (E + 1e-300) over its rays, summed in input order. ``acc``
    (n_cells, 3) is scratch for the numerators."""
    den = np.zeros(n_cells)
    cnt = np.zeros(n_cells, np.int32)
    acc[:] = 0.0
    for i in range(lab.size):
        fc = f[F_CENTRE, i]
        if lab[i] != -1 and lab[i] < 1 and fc >= 0 and fc < n_bins:
            cell = rows[i] * n_bins + np.int64(fc)
            ew = f[F_ENERGY, i] + 1e-300
            ewr = ew * r[i]
            den[cell] += ew
            cnt[cell] += 1
            for c in range(3):
                acc[cell, c] += ewr * dirs[i, c]
    nk = 0
    for q in range(n_cells):
        if cnt[q] > 0:
            nk += 1
    xk = np.empty(nk)
    yk = np.empty((3, nk))
    j = 0
    for q in range(n_cells):
        if cnt[q] > 0:
            xk[j] = q
            for c in range(3):
                yk[c, j] = acc[q, c] / den[q]
            j += 1
    return xk, yk


@numba.njit(cache=True, error_model="numpy")
def _interpolate_positions(xk, yk, origin, want, n_rows, n_bins, bins_first, out):
    """Write into ``out`` (n_rows · n_bins, 3) the hit position of each wanted cell (cells
    indexed row · n_bins + bin; the output likewise or, with ``bins_first``, bin · n_rows
    + row): origin + the known means (xk, yk) linearly interpolated over the cell index
    (held constant beyond the first and last), exactly as ``origin[c] + np.interp(query,
    known, …)``; NaN where not wanted or nothing is known."""
    nk = xk.size
    if nk == 0:
        out[:] = np.nan
        return
    slopes = np.empty((nk, 3))  # numpy's interpolation slope of each segment
    for j in range(nk - 1):
        for c in range(3):
            slopes[j, c] = (yk[c, j + 1] - yk[c, j]) / (xk[j + 1] - xk[j])
    # the output in its own order (rows × bins or bins × rows), one search pointer per row
    jr = np.empty(n_rows, np.int64)
    for r in range(n_rows):
        jr[r] = max(np.searchsorted(xk, r * n_bins, side="right") - 1, 0)
    n_out, n_in = (n_bins, n_rows) if bins_first else (n_rows, n_bins)
    for u in range(n_out):
        for v in range(n_in):
            t = u * n_in + v
            r = v if bins_first else u
            q = v * n_bins + u if bins_first else t
            if not want[q]:
                out[t, 0] = out[t, 1] = out[t, 2] = np.nan
                continue
            x = float(q)
            j = jr[r]
            while j + 1 < nk and xk[j + 1] <= x:
                j += 1
            jr[r] = j
            if x <= xk[0] or j == nk - 1 or xk[j] == x:  # at or beyond a known cell
                k = 0 if x <= xk[0] else j
                out[t, 0] = origin[0] + yk[0, k]
                out[t, 1] = origin[1] + yk[1, k]
                out[t, 2] = origin[2] + yk[2, k]
                continue
            dx = x - xk[j]
            for c in range(3):
                w = slopes[j, c] * dx + yk[c, j]
                if np.isnan(w):
                    w = slopes[j, c] * (x - xk[j + 1]) + yk[c, j + 1]
                    if np.isnan(w) and yk[c, j] == yk[c, j + 1]:
                        w = yk[c, j]
                out[t, c] = origin[c] + w


@numba.njit(cache=True, error_model="numpy")
def image_pass(rows, f, lab, k, sub, src, r, dirs, origin, n_rows, n_bins, bins_first):
    """Mean (n_rows, n_bins) of the background footprints (shaped splat of
    :func:`_shaped_boxes`), labels (n_rows, n_bins) int32 (:func:`label_cells`), the
    background hit positions (n_rows · n_bins, 3) world m (:func:`_centre_means`
    interpolated along range; NaN where the label is −1) and each footprint's cell span
    [start, end). ``f``: :func:`sim.sonar.echo_kernels.footprint_pass`'s terms; ``sub``,
    ``src``: :func:`sim.sonar.echo_kernels.subbox_pass`'s, log-weights exponentiated."""
    rr, aa, bb, ee = _shaped_boxes(rows, f, k, sub, src)
    mean = splat_boxes(rr, aa, bb, ee, n_rows, n_bins)
    n = lab.size
    bg = np.empty(n, np.bool_)
    for i in range(n):
        bg[i] = lab[i] != -1 and lab[i] < 1
    labels, start, end = label_cells(rows, f[F_START], f[F_END], bg, lab, n_rows, n_bins)
    size = n_rows * n_bins
    pos = np.empty((size, 3))
    xk, yk = _centre_means(f, lab, rows, r, dirs, size, n_bins, pos)
    _interpolate_positions(xk, yk, origin, labels.reshape(-1) != -1, n_rows, n_bins,
                           bins_first, pos)  # fmt: skip
    return mean, labels, pos, start, end

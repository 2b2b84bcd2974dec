"""Compiled loops of echo formation (:mod:`sim.sonar.echo`): the range-cell scatters.

Each function does in one pass what the array version did in a chain of ``np.bincount``,
``np.cumsum`` and ``np.interp`` calls, with the same floating-point operations in the same
order (sums accumulated in input order, prefix sums along the row, numpy's interpolation
formula and its special cases), so the results are the same bytes
(tests/sim/sonar/test_sonar_echo.py compares them with the array version). Compiled by
numba on first use and cached on disk (``cache=True``).
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True)
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


@numba.njit(cache=True)
def covered(rows, start, end, n_rows, n_bins):
    """Bool (n_rows, n_bins): cells covered by at least one integer span [start, end)
    of row ``rows`` (spans clipped to [0, n_bins] by the caller)."""
    stride = n_bins + 1
    c = np.zeros(n_rows * stride, np.int64)
    for i in range(rows.size):
        c[rows[i] * stride + start[i]] += 1
        c[rows[i] * stride + end[i]] -= 1
    out = np.empty((n_rows, n_bins), np.bool_)
    for r in range(n_rows):
        s = 0
        for k in range(n_bins):
            s += c[r * stride + k]
            out[r, k] = s > 0
    return out


@numba.njit(cache=True)
def background_positions(cell, ew, ewr, d, origin, want, n_rows, n_bins, bins_first):
    """Hit position (n_rows · n_bins, 3) world m of each wanted cell, NaN elsewhere; cells
    are indexed row · n_bins + bin (``cell``, ``want``), the output likewise or, with
    ``bins_first``, bin · n_rows + row.

    Cells holding rays' footprint centres (``cell`` (M,) int64, energies ``ew``, ``ewr`` =
    ew·r, directions ``d`` (M, 3)) get origin + Σ E·r·d / Σ E; every wanted cell gets that
    value linearly interpolated over the cell index between such cells (held constant
    beyond the first and last), exactly as ``origin[c] + np.interp(query, known, …)``.
    """
    size = n_rows * n_bins
    den = np.zeros(size)
    num = np.zeros((3, size))
    for i in range(cell.size):
        den[cell[i]] += ew[i]
    for c in range(3):
        for i in range(cell.size):
            num[c, cell[i]] += ewr[i] * d[i, c]
    out = np.full((size, 3), np.nan)
    nk = 0
    for k in range(size):
        if den[k] > 0:
            nk += 1
    if nk == 0:
        return out
    xk = np.empty(nk)
    yk = np.empty((3, nk))
    j = 0
    for k in range(size):
        if den[k] > 0:
            xk[j] = k
            for c in range(3):
                yk[c, j] = num[c, k] / den[k]
            j += 1
    j = 0
    for q in range(size):
        if not want[q]:
            continue
        x = float(q)
        t = (q % n_bins) * n_rows + q // n_bins if bins_first else q
        while j + 1 < nk and xk[j + 1] <= x:
            j += 1
        for c in range(3):
            if x <= xk[0]:
                v = yk[c, 0]
            elif j == nk - 1 or xk[j] == x:
                v = yk[c, j]
            else:
                slope = (yk[c, j + 1] - yk[c, j]) / (xk[j + 1] - xk[j])
                v = slope * (x - xk[j]) + yk[c, j]
                if np.isnan(v):
                    v = slope * (x - xk[j + 1]) + yk[c, j + 1]
                    if np.isnan(v) and yk[c, j] == yk[c, j + 1]:
                        v = yk[c, j]
            out[t, c] = origin[c] + v
    return out


@numba.njit(cache=True)
def neighbour_log_slope(idx, fc, log_rho, r_bins, link):
    """d ln(density)/d(bin) of rays ``idx`` from their linked neighbours j ± 1 (mean of
    (log_rho[j] − log_rho[i]) / (fc[j] − fc[i]) over both sides), else −3 / max(r, 1)."""
    n = fc.size
    out = np.empty(idx.size)
    for i in range(idx.size):
        ii = idx[i]
        tot = 0.0
        cnt = 0.0
        for side in (-1, 1):
            j = ii + side
            jj = min(max(j, 0), n - 1)
            ok = j >= 0 and j < n and link[min(max(min(ii, jj), 0), n - 2)]
            dfc = fc[jj] - fc[ii]
            if ok and abs(dfc) > 1e-6:
                tot += (log_rho[jj] - log_rho[ii]) / dfc
                cnt += 1.0
        out[i] = tot / max(cnt, 1.0) if cnt > 0 else -3.0 / max(r_bins[ii], 1.0)
    return out


@numba.njit(cache=True)
def sub_boxes(wide, kw, width, a, fc, slope):
    """Split footprint [a, a + width) of each ray ``wide[i]`` into ``kw[i]`` equal
    sub-boxes: (source ray, start, end, clip(slope·(centre − fc), ±30)) per sub-box."""
    total = 0
    for i in range(kw.size):
        total += kw[i]
    src = np.empty(total, np.int64)
    sa = np.empty(total)
    sb = np.empty(total)
    x = np.empty(total)
    p = 0
    for i in range(wide.size):
        w = wide[i]
        step = width[w] / kw[i]
        for j in range(kw[i]):
            lo = a[w] + j * step
            hi = lo + step
            src[p] = w
            sa[p] = lo
            sb[p] = hi
            x[p] = min(max(slope[i] * (0.5 * (lo + hi) - fc[w]), -30.0), 30.0)
            p += 1
    return src, sa, sb, x


@numba.njit(cache=True)
def share_energy(kw, weight, e, src):
    """Energy of each sub-box: its ray's energy × weight / (sum of the ray's weights)."""
    out = np.empty(weight.size)
    p = 0
    for i in range(kw.size):
        s = 0.0
        for j in range(kw[i]):
            s += weight[p + j]
        for j in range(kw[i]):
            out[p + j] = e[src[p + j]] * (weight[p + j] / s)
        p += kw[i]
    return out

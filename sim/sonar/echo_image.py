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
def _box_term(row, a, b, e, n_bins):
    """Second-difference terms of energy ``e`` spread uniformly over the fractional bin
    span [a, b) of ``row``: slots ba, bb of its clipped ends (row-major, n_bins + 3 per
    row, one leading slot), density rho = e / (b − a) and the ends' fractions fa, fb into
    their bins. Scalars only (array arguments would cost reference counting per call)."""
    aa = min(max(a, 0.0), float(n_bins))
    ab = min(max(b, 0.0), float(n_bins))
    ia = np.floor(aa)
    ib = np.floor(ab)
    base = row * (n_bins + 3) + 1
    return base + np.int64(ia), base + np.int64(ib), e / (b - a), aa - ia, ab - ib


@numba.njit(cache=True, error_model="numpy")
def _splat_sum(ba, bb, rho, fa, fb, m, n_rows, n_bins):
    """(n_rows, n_bins) cell values, clipped at 0, of the first ``m`` boxes of
    :func:`_box_term`: a kink of slope s at fractional position p = i + f adds s(1 − f)
    at i + 1 and s·f at i + 2 of a second-difference array whose prefix sum along the
    row is the cell value."""
    stride = n_bins + 3
    d2 = np.zeros(n_rows * stride)
    # the four terms in the order np.bincount saw them (all boxes' first terms, then …)
    for i in range(m):
        d2[ba[i]] += rho[i] * (1.0 - fa[i])
    for i in range(m):
        d2[ba[i] + 1] += rho[i] * fa[i]
    for i in range(m):
        d2[bb[i]] += -rho[i] * (1.0 - fb[i])
    for i in range(m):
        d2[bb[i] + 1] += -rho[i] * fb[i]
    out = np.empty((n_rows, n_bins))
    for r in range(n_rows):
        s = d2[r * stride]
        for k in range(n_bins):
            s += d2[r * stride + k + 1]
            out[r, k] = s if s >= 0.0 else 0.0
    return out


@numba.njit(cache=True)
def _box_arrays(m):
    """Empty ba, bb (int64), rho, fa, fb arrays for m boxes."""
    return (np.empty(m, np.int64), np.empty(m, np.int64), np.empty(m), np.empty(m), np.empty(m))


@numba.njit(cache=True, error_model="numpy")
def splat_boxes(rows, a, b, e, n_rows, n_bins):
    """Energies ``e`` (N,) spread uniformly over fractional bin spans [a, b) of row
    ``rows`` (N,) int64; returns (n_rows, n_bins) float64, clipped at 0."""
    n = rows.size
    ba, bb, rho, fa, fb = _box_arrays(n)
    for i in range(n):
        ba[i], bb[i], rho[i], fa[i], fb[i] = _box_term(rows[i], a[i], b[i], e[i], n_bins)
    return _splat_sum(ba, bb, rho, fa, fb, n, n_rows, n_bins)


@numba.njit(cache=True, error_model="numpy")
def _span(a, b, n_bins):
    """A footprint's integer cell span [floor(a), ceil(b)) clipped to [0, n_bins]."""
    s = np.int64(min(max(np.floor(a), 0.0), float(n_bins)))
    t = np.int64(min(max(np.ceil(b), 0.0), float(n_bins)))
    return s, t


@numba.njit(cache=True, error_model="numpy")
def _labels(c_sb, c_ot, n_rows, n_bins):
    """Labels (n_rows, n_bins) int32 from the coverage counts of the background footprints
    (+1 / −1 at the ends of each span, n_bins + 1 per row): ``c_sb`` of the seabed's
    (label 0), ``c_ot`` of unlabelled geoms' (−2): 0 where a seabed footprint covers the
    cell, else −2 where an unlabelled geom's does, else −1."""
    stride = n_bins + 1
    labels = np.empty((n_rows, n_bins), np.int32)
    for q in range(n_rows):
        s0 = 0
        s1 = 0
        for k in range(n_bins):
            s0 += c_sb[q * stride + k]
            s1 += c_ot[q * stride + k]
            labels[q, k] = 0 if s0 > 0 else (-2 if s1 > 0 else -1)
    return labels


@numba.njit(cache=True, error_model="numpy")
def label_cells(rows, a, b, lab, n_rows, n_bins):
    """Labels (n_rows, n_bins) int32 of the background footprints (label < 1; see
    :func:`_labels`) and each footprint's integer cell span [start, end) clipped to
    [0, n_bins]."""
    n = rows.size
    start = np.empty(n, np.int64)
    end = np.empty(n, np.int64)
    c_sb = np.zeros(n_rows * (n_bins + 1), np.int64)
    c_ot = np.zeros(n_rows * (n_bins + 1), np.int64)
    stride = n_bins + 1
    for i in range(n):
        s, t = _span(a[i], b[i], n_bins)
        start[i] = s
        end[i] = t
        if lab[i] == 0:
            c_sb[rows[i] * stride + s] += 1
            c_sb[rows[i] * stride + t] -= 1
        elif lab[i] == -2:
            c_ot[rows[i] * stride + s] += 1
            c_ot[rows[i] * stride + t] -= 1
    return _labels(c_sb, c_ot, n_rows, n_bins), start, end


@numba.njit(cache=True, error_model="numpy")
def _centre_means(cell, m, n_cells, f, r, dirs):
    """Known cells (ascending) and their energy-weighted mean hit offsets (3, K) from the
    origin: ``cell`` (N,) the cell row · n_bins + floor(fc) holding ray i's background
    footprint centre (−1: none; ``m`` rays have one); each known cell gets
    Σ (E + 1e-300)·r·d / Σ (E + 1e-300) over its rays, summed in input order (when the
    image has few cells per ray, as the side-scan's, by accumulating into per-cell sums
    in ray order; else over the m rays merge-sorted by cell, as for FLS images)."""
    if n_cells <= 4 * m:
        return _centre_means_dense(cell, n_cells, f, r, dirs)
    idx = np.flatnonzero(cell >= 0)
    order = idx[np.argsort(cell[idx], kind="mergesort")]
    tot = order.size
    nk = 0
    for p in range(tot):
        if p == 0 or cell[order[p]] != cell[order[p - 1]]:
            nk += 1
    xk = np.empty(nk)
    yk = np.empty((3, nk))
    if tot == 0:
        return xk, yk
    j = -1
    den = 0.0
    num = np.zeros(3)
    for p in range(tot + 1):
        if p == tot or (p > 0 and cell[order[p]] != cell[order[p - 1]]):
            for c in range(3):
                yk[c, j] = num[c] / den
            if p == tot:
                break
        i = order[p]
        if p == 0 or cell[i] != cell[order[p - 1]]:
            j += 1
            xk[j] = cell[i]
            den = 0.0
            num[:] = 0.0
        ew = f[F_ENERGY, i] + 1e-300
        ewr = ew * r[i]
        den += ew
        for c in range(3):
            num[c] += ewr * dirs[i, c]
    return xk, yk


@numba.njit(cache=True, error_model="numpy")
def _centre_means_dense(cell, n_cells, f, r, dirs):
    """:func:`_centre_means` by per-cell sums (4 × n_cells) accumulated in ray order: the
    same additions in the same order as the sorted pass, without the sort."""
    acc = np.zeros((n_cells, 4))  # Σ ew, Σ ew·r·d (x, y, z)
    seen = np.zeros(n_cells, np.bool_)
    for i in range(cell.size):
        q = cell[i]
        if q >= 0:
            ew = f[F_ENERGY, i] + 1e-300
            ewr = ew * r[i]
            seen[q] = True
            acc[q, 0] += ew
            acc[q, 1] += ewr * dirs[i, 0]
            acc[q, 2] += ewr * dirs[i, 1]
            acc[q, 3] += ewr * dirs[i, 2]
    nk = 0
    for q in range(n_cells):
        if seen[q]:
            nk += 1
    xk = np.empty(nk)
    yk = np.empty((3, nk))
    j = 0
    for q in range(n_cells):
        if seen[q]:
            xk[j] = q
            for c in range(3):
                yk[c, j] = acc[q, c + 1] / acc[q, 0]
            j += 1
    return xk, yk


@numba.njit(cache=True, error_model="numpy")
def _out_index(row, b, n_rows, n_bins, layout):
    """Index of cell (row, bin b) in a position output of ``layout``: 0 row · n_bins + b,
    1 (bins first) b · n_rows + row, 2 (side-scan ping: row 0 reversed, rows ≤ 2) row 0
    at n_bins − 1 − b, row 1 at n_bins + b."""
    if layout == 1:
        return b * n_rows + row
    if layout == 2 and row == 0:
        return n_bins - 1 - b
    return row * n_bins + b


@numba.njit(cache=True, error_model="numpy")
def _interpolate_positions(xk, yk, origin, want, n_rows, n_bins, layout, out):
    """Write into ``out`` (n_rows · n_bins, 3) the hit position of each wanted cell (cells
    indexed row · n_bins + bin; the output in ``layout``, see :func:`_out_index`):
    origin + the known means (xk, yk) linearly interpolated over the cell index
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
    n_out, n_in = (n_bins, n_rows) if layout == 1 else (n_rows, n_bins)
    for u in range(n_out):
        for v in range(n_in):
            t = u * n_in + v  # the output in its own order (FLS: 131k cells, keep it lean)
            r = v if layout == 1 else u
            q = v * n_bins + u if layout == 1 else t
            if layout == 2 and r == 0:
                t = n_bins - 1 - v
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
def image_pass(rows, f, lab, k, sub, src, r, dirs, origin, n_rows, n_bins, layout):
    """Mean (n_rows, n_bins) of the background footprints, labels (n_rows, n_bins) int32
    (as :func:`label_cells`), the background hit positions (n_rows · n_bins, 3) world m
    in ``layout`` (:func:`_out_index`; :func:`_centre_means` interpolated along range;
    NaN where the label is −1) and each
    footprint's cell span [start, end). ``f``:
    :func:`sim.sonar.echo_kernels.footprint_pass`'s terms; ``sub``, ``src``:
    :func:`sim.sonar.echo_kernels.subbox_pass`'s, log-weights exponentiated.

    The mean is the splat of the footprints with one sub-box (k == 1, in ray order)
    followed by the sub-boxes, each getting its ray's background energy × weight / (sum
    of the ray's weights). One loop over the rays collects their label spans, centre
    cells and one-box terms."""
    n = lab.size
    n_cells = n_rows * n_bins
    start = np.empty(n, np.int64)
    end = np.empty(n, np.int64)
    c_sb = np.zeros(n_rows * (n_bins + 1), np.int64)
    c_ot = np.zeros(n_rows * (n_bins + 1), np.int64)
    cell = np.empty(n, np.int64)
    n_centre = 0
    ba, bb, rho, fa, fb = _box_arrays(n + src.size)
    m = 0
    for i in range(n):
        a = f[F_START, i]
        b = f[F_END, i]
        s, t = _span(a, b, n_bins)
        start[i] = s
        end[i] = t
        li = lab[i]
        if li == 0:
            c_sb[rows[i] * (n_bins + 1) + s] += 1
            c_sb[rows[i] * (n_bins + 1) + t] -= 1
        elif li == -2:
            c_ot[rows[i] * (n_bins + 1) + s] += 1
            c_ot[rows[i] * (n_bins + 1) + t] -= 1
        bg = li == 0 or li == -2
        fc = f[F_CENTRE, i]
        cell[i] = -1
        if bg and fc >= 0 and fc < n_bins:
            cell[i] = rows[i] * n_bins + np.int64(fc)
            n_centre += 1
        if k[i] == 1:
            ba[m], bb[m], rho[m], fa[m], fb[m] = _box_term(rows[i], a, b, f[F_EBG, i], n_bins)
            m += 1
    q = 0
    while q < src.size:  # the sub-boxes, each ray's in turn
        ray = src[q]
        w = 0.0
        for j in range(k[ray]):
            w += sub[2, q + j]
        for j in range(k[ray]):
            e = f[F_EBG, ray] * (sub[2, q + j] / w)
            ba[m], bb[m], rho[m], fa[m], fb[m] = _box_term(
                rows[ray], sub[0, q + j], sub[1, q + j], e, n_bins
            )
            m += 1
        q += k[ray]
    mean = _splat_sum(ba, bb, rho, fa, fb, m, n_rows, n_bins)
    labels = _labels(c_sb, c_ot, n_rows, n_bins)
    xk, yk = _centre_means(cell, n_centre, n_cells, f, r, dirs)
    pos = np.empty((n_cells, 3))
    want = labels.reshape(-1) != -1
    _interpolate_positions(xk, yk, origin, want, n_rows, n_bins, layout, pos)
    return mean, labels, pos, start, end


@numba.njit(cache=True, error_model="numpy")
def object_pass(mean, labels, pos, f, lab, start, end, rows, r, dirs, origin, layout):
    """Add the object footprints (label ≥ 1) to ``mean`` (n_rows, n_bins), ``labels``
    and ``pos`` (n_rows · n_bins, 3; in ``layout``, see :func:`_out_index`) in place.

    Each object footprint is expanded into its cells [start, end) (rays sorted by label,
    stable, so the highest id wins where objects overlap): a cell gets the footprint's
    energy × its overlap fraction (summed per cell in that order, then added to the
    background mean), the label of the last footprint covering it, and as hit position
    the energy-weighted mean of the winning object's hit points. The operations and their
    order are those of the array version (``np.unique`` inverse + ``np.bincount``)."""
    n_rows, n_bins = mean.shape
    obj = np.flatnonzero(lab >= 1)
    obj = obj[np.argsort(lab[obj], kind="mergesort")]
    m = 0
    for i in obj:
        m += max(end[i] - start[i], 0)
    ray = np.empty(m, np.int64)
    ocell = np.empty(m, np.int64)
    e_cell = np.empty(m)
    p = 0
    for i in obj:
        a = f[F_START, i]
        b = f[F_END, i]
        for cb in range(start[i], end[i]):
            ov = min(b, cb + 1.0) - max(a, float(cb))
            ray[p] = i
            ocell[p] = rows[i] * n_bins + cb
            e_cell[p] = f[F_ENERGY, i] * (max(ov, 0.0) / (b - a))
            p += 1
    u = np.unique(ocell)
    slot = np.searchsorted(u, ocell)
    esum = np.zeros(u.size)
    for j in range(m):
        esum[slot[j]] += e_cell[j]
    flat_mean = mean.reshape(-1)
    flat_lab = labels.reshape(-1)
    for q in range(u.size):
        flat_mean[u[q]] += esum[q]
    for j in range(m):
        flat_lab[ocell[j]] = lab[ray[j]]
    den = np.zeros(u.size)
    num = np.zeros((u.size, 3))
    for j in range(m):
        i = ray[j]
        if flat_lab[ocell[j]] == lab[i]:
            ew = e_cell[j] + 1e-300
            den[slot[j]] += ew
            for c in range(3):
                num[slot[j], c] += ew * (origin[c] + dirs[i, c] * r[i])
    for q in range(u.size):
        cell = u[q]
        t = _out_index(cell // n_bins, cell % n_bins, n_rows, n_bins, layout)
        for c in range(3):
            pos[t, c] = num[q, c] / den[q]

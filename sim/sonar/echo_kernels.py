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
def background_positions(cell, ew, ewr, d, origin, want, n_rows, n_bins, bins_first, order):
    """Hit position (n_rows · n_bins, 3) world m of each wanted cell, NaN elsewhere; cells
    are indexed row · n_bins + bin (``cell``, ``want``), the output likewise or, with
    ``bins_first``, bin · n_rows + row.

    ``order``: the sorted keys of :func:`centre_cells` (cells ascending, each cell's rays
    in input order).
    Cells holding rays' footprint centres (``cell`` (M,) int64, energies ``ew`` > 0,
    ``ewr`` = ew·r, directions ``d`` (M, 3)) get origin + Σ E·r·d / Σ E (sums in input
    order); every wanted cell gets that value linearly interpolated over the cell index
    between such cells (held constant beyond the first and last), exactly as
    ``origin[c] + np.interp(query, known, …)``.
    """
    size = n_rows * n_bins
    out = np.empty((size, 3))
    order = order % max(cell.size, 1)  # sorted keys → ray indices
    nk = 0
    for i in range(order.size):
        if i == 0 or cell[order[i]] != cell[order[i - 1]]:
            nk += 1
    if nk == 0:
        out[:] = np.nan
        return out
    xk = np.empty(nk)
    yk = np.empty((3, nk))
    j = -1
    den = 0.0
    num = np.zeros(3)
    for i in range(order.size + 1):
        if i == order.size or (i > 0 and cell[order[i]] != cell[order[i - 1]]):
            for c in range(3):
                yk[c, j] = num[c] / den
            if i == order.size:
                break
        o = order[i]
        if i == 0 or cell[o] != cell[order[i - 1]]:
            j += 1
            xk[j] = cell[o]
            den = 0.0
            num[:] = 0.0
        den += ew[o]
        for c in range(3):
            num[c] += ewr[o] * d[o, c]
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


@numba.njit(cache=True)
def ray_terms(geom, dist, normal, dirs, d_dirs, geom_object_id, geom_reflectivity):
    """Per ray: hit (geom ≥ 0), geom (0 for a miss), range r m (0 for a miss),
    |n·d| = cos θ, |n·∂d|, reflectivity of the geom and label (object id, −2 for a hit on
    an unlabelled geom, −1 for a miss) as int32."""
    n = geom.size
    hit = np.empty(n, np.bool_)
    g = np.empty(n, np.int64)
    r = np.empty(n)
    cos_i = np.empty(n)
    ndd = np.empty(n)
    refl = np.empty(n)
    lab = np.empty(n, np.int32)
    for i in range(n):
        h = geom[i] >= 0
        hit[i] = h
        gi = geom[i] if h else 0
        g[i] = gi
        r[i] = dist[i] if h else 0.0
        cos_i[i] = abs(
            normal[i, 0] * dirs[i, 0] + normal[i, 1] * dirs[i, 1] + normal[i, 2] * dirs[i, 2]
        )
        ndd[i] = abs(
            normal[i, 0] * d_dirs[i, 0] + normal[i, 1] * d_dirs[i, 1] + normal[i, 2] * d_dirs[i, 2]
        )
        refl[i] = geom_reflectivity[gi]
        lb = np.int32(geom_object_id[gi]) if h else np.int32(-1)
        lab[i] = np.int32(-2) if (h and lb < 0) else lb
    return hit, g, r, cos_i, ndd, refl, lab


@numba.njit(cache=True)
def footprints(
    gain, refl, soc, att, r, hit, ndd, cos_i, lab, d_dirs, neighbours, r_min, bin_width,
    n_bins, footprint_scale, min_ext, max_ext, max_fraction,
):  # fmt: skip
    """Energy (gain·refl·σ/cos·att / max(r, 1 mm)², 0 for a miss), the same on background
    hits only (0 on objects), background-hit mask, footprint centre fc and
    ends [a, b) in fractional bins (see :func:`sim.sonar.echo.form_echo`), and the links
    (N − 1,) between consecutive ``neighbours`` rays on the same labelled surface, whose
    facing footprint ends meet where their shared angular cell edge lands."""
    n = r.size
    energy = np.empty(n)
    e_bg = np.empty(n)
    bg = np.empty(n, np.bool_)
    fc = np.empty(n)
    a = np.empty(n)
    b = np.empty(n)
    off = n_bins + max_ext + 1.0  # off the end: contributes nothing
    for i in range(n):
        rs = max(r[i], 1e-3)
        e = gain[i] * refl[i] * soc[i]
        energy[i] = e * (att[i] / (rs * rs)) if hit[i] else 0.0
        bg[i] = hit[i] and lab[i] < 1  # objects (label ≥ 1) are added separately
        e_bg[i] = energy[i] if bg[i] else 0.0
        ext = min(r[i] * ndd[i] / max(cos_i[i], 0.02), max_fraction * r[i]) / bin_width
        ext = min(max(ext * footprint_scale, min_ext), max_ext)
        f = (r[i] - r_min) / bin_width if hit[i] else off
        fc[i] = f
        a[i] = f - 0.5 * ext
        b[i] = f + 0.5 * ext
    if neighbours is None:
        return energy, e_bg, bg, fc, a, b, np.zeros(0, np.bool_)
    link = np.empty(n - 1, np.bool_)
    mid = np.empty(n - 1)
    w = np.empty(n)
    for i in range(n):
        w[i] = np.sqrt(
            d_dirs[i, 0] * d_dirs[i, 0] + d_dirs[i, 1] * d_dirs[i, 1] + d_dirs[i, 2] * d_dirs[i, 2]
        )
    for j in range(n - 1):
        link[j] = neighbours[j] and hit[j] and hit[j + 1] and lab[j] == lab[j + 1]
        t = w[j] / max(w[j] + w[j + 1], 1e-300)
        mid[j] = fc[j] + t * (fc[j + 1] - fc[j])
    half = 0.5 * min_ext
    # the four updates in turn over all links (a later one overrides an earlier one)
    for j in range(n - 1):
        if link[j] and fc[j + 1] > fc[j]:
            b[j] = max(mid[j], fc[j] + half)
    for j in range(n - 1):
        if link[j] and fc[j + 1] > fc[j]:
            a[j + 1] = min(mid[j], fc[j + 1] - half)
    for j in range(n - 1):
        if link[j] and fc[j + 1] <= fc[j]:
            a[j] = min(mid[j], fc[j] - half)
    for j in range(n - 1):
        if link[j] and fc[j + 1] <= fc[j]:
            b[j + 1] = max(mid[j], fc[j + 1] + half)
    return energy, e_bg, bg, fc, a, b, link


@numba.njit(cache=True)
def split_widths(a, b, e, subbox_bins, max_subboxes):
    """Sub-box count per footprint (ceil(width / subbox_bins) clipped to [1,
    max_subboxes]), the indices of the wide (count > 1) footprints and the argument
    e / max(width, 1e-9) clipped below at 1e-300 of their log box density."""
    n = a.size
    k = np.empty(n, np.int64)
    dens = np.empty(n)
    nw = 0
    for i in range(n):
        width = b[i] - a[i]
        k[i] = np.int64(min(max(np.ceil(width / subbox_bins), 1.0), max_subboxes))
        dens[i] = max(e[i] / max(width, 1e-9), 1e-300)
        if k[i] > 1:
            nw += 1
    wide = np.empty(nw, np.int64)
    p = 0
    for i in range(n):
        if k[i] > 1:
            wide[p] = i
            p += 1
    return k, wide, dens


@numba.njit(cache=True)
def splat_narrow_and_sub(rows, a, b, e, k, src, sa, sb, e_sub, n_rows, n_bins):
    """:func:`splat_boxes` of the footprints with one sub-box (k == 1) followed by the
    sub-boxes (source ray ``src``, spans [sa, sb), energies ``e_sub``), in that order."""
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
            rr[p], aa[p], bb[p], ee[p] = rows[i], a[i], b[i], e[i]
            p += 1
    for j in range(src.size):
        rr[p], aa[p], bb[p], ee[p] = rows[src[j]], sa[j], sb[j], e_sub[j]
        p += 1
    return splat_boxes(rr, aa, bb, ee, n_rows, n_bins)


@numba.njit(cache=True)
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


@numba.njit(cache=True)
def centre_cells(bg, fc, rows, energy, r, dirs, n_bins):
    """The background rays whose footprint centre lies in the image: their cells
    (row · n_bins + floor(fc)), energies + 1e-300, energy · range, directions, and the
    unique sort keys cell · M + k (k: their order here, M: their count)."""
    m = 0
    for i in range(fc.size):
        if bg[i] and fc[i] >= 0 and fc[i] < n_bins:
            m += 1
    cell = np.empty(m, np.int64)
    key = np.empty(m, np.int64)
    ew = np.empty(m)
    ewr = np.empty(m)
    d = np.empty((m, 3))
    p = 0
    for i in range(fc.size):
        if bg[i] and fc[i] >= 0 and fc[i] < n_bins:
            cell[p] = rows[i] * n_bins + np.int64(fc[i])
            key[p] = cell[p] * m + p
            ew[p] = energy[i] + 1e-300
            ewr[p] = ew[p] * r[i]
            d[p, 0], d[p, 1], d[p, 2] = dirs[i, 0], dirs[i, 1], dirs[i, 2]
            p += 1
    return cell, key, ew, ewr, d

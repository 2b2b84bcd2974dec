"""Compiled per-ray passes of echo formation (:mod:`sim.sonar.echo`).

Three passes over a ping's rays, each writing its per-ray terms into one 2-D array (one
row per term) instead of a chain of one-output numpy calls: :func:`ray_pass` (incidence,
footprint derivative, reflectivity, label, the absorption exponent), :func:`footprint_pass`
(energies, footprint ends, neighbour links, sub-box counts) and :func:`subbox_pass` (the
sub-boxes of wide footprints and their log-weights). Between them the caller applies
numpy's ``exp``, ``log`` and ``arccos`` in place (its SIMD results differ from libm's in
the last bit; keeping them in numpy keeps every output the same bytes as the array
version, tests/helpers/legacy_echo.py). The range-cell scatters are in
:mod:`sim.sonar.echo_image`. Compiled by numba on first use, cached on disk.

Every floating-point operation is the one the array version did, in the same order.
"""

from __future__ import annotations

import numba
import numpy as np

# rows of ray_pass's output
R_RANGE, R_COS, R_NDD, R_REFL, R_SOC, R_ATT, R_DDNORM = range(7)
# rows of footprint_pass's output
F_ENERGY, F_EBG, F_CENTRE, F_START, F_END, F_DENS = range(6)


@numba.njit(cache=True, error_model="numpy")
def ray_pass(geom, dist, normal, dirs, d_dirs, geom_object_id, geom_reflectivity, cos_near, att_k):
    """Per-ray terms (7, N) float64 — range r m (0 for a miss), cos θ = |n·d|, |n·∂d|,
    reflectivity of the geom, σ/(μ cos θ) before the specular lobe (= cos θ), the
    absorption exponent att_k·r (to be exponentiated) and |∂d| — plus the labels (N,)
    int32 (object id, −2 for a hit on an unlabelled geom, −1 for a miss), the indices
    of the rays with cos θ > ``cos_near`` (the specular lobe's support) and the number
    of rays on objects (label ≥ 1)."""
    n = geom.size
    t = np.empty((7, n))
    lab = np.empty(n, np.int32)
    near = np.empty(n, np.int64)
    p = 0
    n_obj = 0
    for i in range(n):
        h = geom[i] >= 0
        gi = geom[i] if h else 0
        r = dist[i] if h else 0.0
        c = abs(normal[i, 0] * dirs[i, 0] + normal[i, 1] * dirs[i, 1] + normal[i, 2] * dirs[i, 2])
        t[R_RANGE, i] = r
        t[R_COS, i] = c
        t[R_NDD, i] = abs(
            normal[i, 0] * d_dirs[i, 0] + normal[i, 1] * d_dirs[i, 1] + normal[i, 2] * d_dirs[i, 2]
        )
        t[R_REFL, i] = geom_reflectivity[gi]
        t[R_SOC, i] = c
        t[R_ATT, i] = att_k * r
        t[R_DDNORM, i] = np.sqrt(
            d_dirs[i, 0] * d_dirs[i, 0] + d_dirs[i, 1] * d_dirs[i, 1] + d_dirs[i, 2] * d_dirs[i, 2]
        )
        lb = np.int32(geom_object_id[gi]) if h else np.int32(-1)
        lab[i] = np.int32(-2) if (h and lb < 0) else lb
        if lab[i] >= 1:
            n_obj += 1
        if c > cos_near:
            near[p] = i
            p += 1
    return t, lab, near[:p], n_obj


@numba.njit(cache=True, error_model="numpy")
def footprint_pass(
    gain, t, lab, neighbours, use_links, r_min, bin_width, n_bins, footprint_scale,
    min_ext, max_ext, max_fraction, subbox_bins, max_subboxes,
):  # fmt: skip
    """From :func:`ray_pass`'s terms (absorption exponentiated): per ray (6, N) — energy
    gain·refl·σ/cos·att / max(r, 1 mm)² (0 for a miss), the same on background hits only
    (label < 1; 0 elsewhere), footprint centre fc and ends [a, b) in fractional bins (see
    :func:`sim.sonar.echo.form_echo`), and the box density e_bg / max(b − a, 1e-9)
    clipped below at 1e-300 (the argument of the sub-box log-slope) — the links (N − 1,)
    between consecutive ``neighbours`` rays on the same labelled surface (all False
    without ``use_links``), whose facing footprint ends meet where their shared angular
    cell edge lands, the sub-box count per footprint (ceil(width / subbox_bins) in [1,
    max_subboxes]), the indices of the footprints with more than one and those of the rays
    whose log density the sub-box slopes read (each such footprint and its neighbours).

    Simple loops over the rays (not one fused loop: LLVM vectorizes the first, and the
    fused loop ran 1.8× slower)."""
    n = lab.size
    f = np.empty((6, n))
    off = n_bins + max_ext + 1.0  # off the end: contributes nothing
    for i in range(n):
        r = t[R_RANGE, i]
        hit = lab[i] != -1
        rs = max(r, 1e-3)
        e = gain[i] * t[R_REFL, i] * t[R_SOC, i]
        en = e * (t[R_ATT, i] / (rs * rs)) if hit else 0.0
        f[F_ENERGY, i] = en
        f[F_EBG, i] = en if (hit and lab[i] < 1) else 0.0  # objects are added separately
        ext = min(r * t[R_NDD, i] / max(t[R_COS, i], 0.02), max_fraction * r) / bin_width
        ext = min(max(ext * footprint_scale, min_ext), max_ext)
        fc = (r - r_min) / bin_width if hit else off
        f[F_CENTRE, i] = fc
        f[F_START, i] = fc - 0.5 * ext
        f[F_END, i] = fc + 0.5 * ext
    link = np.zeros(max(n - 1, 0), np.bool_)
    if use_links:
        _link_ends(f, t[R_DDNORM], lab, neighbours, link, min_ext)
    k = np.empty(n, np.int64)
    nw = 0
    for i in range(n):
        width = f[F_END, i] - f[F_START, i]
        k[i] = np.int64(min(max(np.ceil(width / subbox_bins), 1.0), max_subboxes))
        f[F_DENS, i] = max(f[F_EBG, i] / max(width, 1e-9), 1e-300)
        if k[i] > 1:
            nw += 1
    wide = np.empty(nw, np.int64)
    need = np.empty(3 * nw, np.int64)
    p = 0
    m = 0
    for i in range(n):
        if k[i] > 1:
            wide[p] = i
            p += 1
            for j in range(max(i - 1, 0), min(i + 2, n)):
                if m == 0 or j > need[m - 1]:
                    need[m] = j
                    m += 1
    return f, link, k, wide, need[:m]


@numba.njit(cache=True, error_model="numpy")
def _link_ends(f, w, lab, neighbours, link, min_ext):
    """Set ``link`` and move the facing footprint ends of linked rays to the point between
    their centres weighted by their angular widths ``w`` (the four updates in turn over
    all links: a later one overrides an earlier one)."""
    n = lab.size
    fc = f[F_CENTRE]
    a = f[F_START]
    b = f[F_END]
    mid = np.empty(n - 1)
    for j in range(n - 1):
        link[j] = neighbours[j] and lab[j] != -1 and lab[j + 1] != -1 and lab[j] == lab[j + 1]
        s = w[j] / max(w[j] + w[j + 1], 1e-300)
        mid[j] = fc[j] + s * (fc[j + 1] - fc[j])
    half = 0.5 * min_ext
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


@numba.njit(cache=True, error_model="numpy")
def subbox_pass(wide, k, f, link, r, bin_width):
    """Split footprint [a, b) of each ray ``wide[i]`` into ``k`` equal sub-boxes: (3, M)
    rows start, end and clip(slope·(centre − fc), ±30) (the log-weight, to be
    exponentiated), and the source ray (M,) of each. ``f[F_DENS]`` holds log densities:
    the slope is the mean of (log ρ_j − log ρ_i) / (fc_j − fc_i) over the linked
    neighbours j = i ± 1, else −3 / max(r / bin_width, 1)."""
    n = k.size
    fc = f[F_CENTRE]
    log_rho = f[F_DENS]
    total = 0
    for i in range(wide.size):
        total += k[wide[i]]
    sub = np.empty((3, total))
    src = np.empty(total, np.int64)
    p = 0
    for i in range(wide.size):
        ii = wide[i]
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
        slope = tot / max(cnt, 1.0) if cnt > 0 else -3.0 / max(r[ii] / bin_width, 1.0)
        step = (f[F_END, ii] - f[F_START, ii]) / k[ii]
        for j in range(k[ii]):
            lo = f[F_START, ii] + j * step
            hi = lo + step
            src[p] = ii
            sub[0, p] = lo
            sub[1, p] = hi
            sub[2, p] = min(max(slope * (0.5 * (lo + hi) - fc[ii]), -30.0), 30.0)
            p += 1
    return sub, src


@numba.njit(cache=True, error_model="numpy")
def lobe_cos(t, near):
    """min(cos θ, 1) of the rays ``near`` (:func:`ray_pass`'s terms ``t``): the argument
    of the specular lobe's arccos."""
    cn = np.empty(near.size)
    for q in range(near.size):
        cn[q] = min(t[R_COS, near[q]], 1.0)
    return cn


@numba.njit(cache=True, error_model="numpy")
def lobe_exponent(th, width):
    """The specular lobe's exponent −0.5·(θ / width)², in place over θ (rad)."""
    for q in range(th.size):
        x = th[q] / width
        th[q] = -0.5 * (x * x)


@numba.njit(cache=True, error_model="numpy")
def add_lobe(t, near, cn, lobe, peak):
    """Add the specular lobe to σ/(μ cos θ) of the rays ``near``: peak · lobe /
    max(cos θ, 0.05) (``lobe`` = exp of :func:`lobe_exponent`, ``cn`` of
    :func:`lobe_cos`)."""
    for q in range(near.size):
        t[R_SOC, near[q]] += peak * lobe[q] / max(cn[q], 0.05)

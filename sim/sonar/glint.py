"""Target glints: double-bounce (corner) returns of objects and FLS azimuth sidelobes.

Corner returns: every ray that hits an object (label ≥ 1) is reflected specularly
(d' = d − 2(d·n)n) and traced once more through the static scene; where the second
surface (the same object, another object or the seabed: hull–seabed and
deck–superstructure dihedrals) reflects it back towards the transducer, within a lobe of
width w about the exact return direction, the ray adds σ_c/μ = G·refl₁·refl₂·exp(−ε²/2w²)
at half the path length (ε: angle between the doubly reflected ray and the direction
back to the sonar). A dihedral returns energy over a wide range of incidence angles in
the plane normal to its edge, which is why wrecks glint (Lurton 2010, §3.6; Urick 1983,
table 9.1, corner reflectors).

FLS azimuth sidelobes: each beam receives, besides its main lobe, the echoes of the other
beams' directions through its sidelobes: the beams' mean images are convolved across
beams with the receive pattern of a uniform line array (sinc², first sidelobe at
``fls_azimuth_sidelobe_db``, i.e. a shaded array) evaluated at the beam-angle offsets.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import fftconvolve

SECOND_BOUNCE_M = 15.0  # longest second leg traced, m


def corner_returns(
    backend,
    origin,
    dirs,
    hits,
    gain,
    rows,
    geom_object_id,
    geom_reflectivity,
    peak,
    width,
    alpha_db_m,
    r_min,
    bin_width,
    n_rows,
    n_bins,
):
    """(n_rows, n_bins) mean corner-return intensity (µPa²), or None when no object ray
    returns (or the backend cannot cast from many origins). Arguments as for form_echo;
    peak: G/μ (linear), width: lobe width (rad)."""
    if not hasattr(backend, "cast_static"):
        return None
    hit = hits.geom >= 0
    oid = np.where(hit, geom_object_id[np.where(hit, hits.geom, 0)], -1)
    idx = np.flatnonzero(oid >= 1)
    if idx.size == 0:
        return None
    d = dirs[idx]
    n = hits.normal[idx]
    r1 = hits.dist[idx]
    p1 = origin[None, :] + d * r1[:, None]
    d2 = d - 2.0 * np.sum(d * n, axis=1, keepdims=True) * n
    h2 = backend.cast_static(p1 - 2e-3 * d, d2, SECOND_BOUNCE_M)
    ok = np.flatnonzero(np.isfinite(h2.dist) & (h2.geom >= 0))
    if ok.size == 0:
        return None
    l2 = h2.dist[ok]
    p2 = p1[ok] + d2[ok] * l2[:, None]
    n2 = h2.normal[ok]
    d3 = d2[ok] - 2.0 * np.sum(d2[ok] * n2, axis=1, keepdims=True) * n2
    back = origin[None, :] - p2
    l3 = np.linalg.norm(back, axis=1)
    cos_e = np.sum(d3 * back, axis=1) / np.maximum(l3, 1e-9)
    eps = np.arccos(np.clip(cos_e, -1.0, 1.0))
    half = 0.5 * (r1[ok] + l2 + l3)
    refl = geom_reflectivity[hits.geom[idx[ok]]] * geom_reflectivity[h2.geom[ok]]
    e = gain[idx[ok]] * peak * refl * np.exp(-0.5 * (eps / width) ** 2)
    e *= np.exp((-0.2 * np.log(10.0) * alpha_db_m) * half) / (half * half)
    b = np.floor((half - r_min) / bin_width).astype(np.int64)
    keep = (b >= 0) & (b < n_bins) & (e > 0)
    cell = rows[idx[ok]][keep] * n_bins + b[keep]
    return np.bincount(cell, e[keep], minlength=n_rows * n_bins).reshape(n_rows, n_bins)


def azimuth_sidelobe_kernel(n_beams: int, dbeta: float, beamwidth: float, first_db: float):
    """(2·n_beams − 1,) sidelobe part of a one-way receive pattern at beam offsets
    −(n−1)…(n−1) × dbeta (rad): sinc² of a line array with −3 dB width ``beamwidth``,
    scaled so its first sidelobe (−13.26 dB unshaded) sits at ``first_db``; 0 inside the
    main lobe (|x| < 1, first null), which the rays spread over a beam already form."""
    k = np.arange(-(n_beams - 1), n_beams) * dbeta
    x = 0.442946 * k / (0.5 * beamwidth)  # np.sinc(x)² = ½ at x = 0.442946 (−3 dB)
    p = np.sinc(x) ** 2
    main = np.abs(x) < 1.0
    scale = 10.0 ** ((first_db + 13.2615) / 10.0)
    return np.where(main, 0.0, p * scale)


def add_azimuth_sidelobes(mean: np.ndarray, kernel: np.ndarray) -> np.ndarray:
    """mean (n_beams, n_bins) plus each beam's echo leaked into the others through the
    sidelobe kernel of :func:`azimuth_sidelobe_kernel` (convolution across beams)."""
    nb = mean.shape[0]
    leak = fftconvolve(mean, kernel[:, None], mode="full", axes=0)[nb - 1 : 2 * nb - 1]
    return mean + np.maximum(leak, 0.0)

"""Echo formation shared by the side-scan, forward-looking and scanning sonars.

Each ray stands for a small solid angle ΔΩ of the transmit/receive beam. A ray hitting a
surface at range r with incidence angle θ (from the normal) insonifies an area
A = r² ΔΩ / cos θ; with Lambert backscatter σ = μ·refl·cos²θ and two-way spreading and
absorption, its mean echo intensity is

    E = SL · b_tx b_rx · ΔΩ · μ · refl · cos θ · r⁻² · 10^(−2 α r / 10)      [µPa²]

(b: one-way beam pattern at the ray's direction; plus an optional near-normal specular
lobe, see ``AcousticConfig.specular_db``). The echo is spread uniformly over the ray's
range footprint: towards a neighbouring ray of the same fan that hit the same labelled
surface, up to the midpoint of the two hits; elsewhere (fan ends, object edges) over the
local-plane extent r · |n·∂d/∂θ| Δθ / |n·d|. Adjacent rays thus tile the range axis
without gaps, and shadows appear where no footprint lands. Binning is a closed-form box
splat: a second-difference array and one prefix sum per image (hand-written: no library
bins box footprints into range cells). A footprint wider than ``SUBBOX_BINS`` is split
into sub-boxes whose energies follow exp(slope·(x − fc)) (normalised per ray; the slope
of log box density from the linked neighbours, else −3 / r in bins), so a coarse fan's
intensity follows the range law inside each footprint instead of stepping between
footprints.

Labels per range cell: the id of the highest-priority class whose footprint covers it
(object k ≥ 1 beats seabed 0 beats unlabelled geoms −2, e.g. vehicles; −1 = no return).
Hit position per cell: for objects, the energy-weighted mean of the hit points of the
object's rays covering the cell; for the background, the energy-weighted mean of the hits
whose footprint centre is in the cell, interpolated along range between such cells (NaN
where the label is −1).

Computed in three compiled per-ray passes (:mod:`sim.sonar.echo_kernels`) and one
compiled image pass (:mod:`sim.sonar.echo_image`, which also adds the object
footprints), with numpy's ``exp``/``log``/``arccos`` applied in place between them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sim.sonar.echo_image import image_pass, object_pass, splat_boxes
from sim.sonar.echo_kernels import (
    F_DENS,
    R_ATT,
    R_COS,
    R_RANGE,
    R_REFL,
    R_SOC,
    add_lobe,
    footprint_pass,
    lobe_cos,
    lobe_exponent,
    ray_pass,
    subbox_pass,
)
from sim.sonar.rays import RayHits

MIN_EXTENT_BINS = 0.5
MAX_EXTENT_BINS = 4096.0
MAX_EXTENT_FRACTION = 0.5  # footprint ≤ half the range (grazing-incidence cap)


@dataclass(frozen=True)
class Echo:
    """mean: (rows, bins) float64 mean echo intensity (µPa²), before speckle/noise/TVG;
    labels: (rows, bins) int32; hit_position: (rows, bins, 3) world m (NaN where label −1)."""

    mean: np.ndarray
    labels: np.ndarray
    hit_position: np.ndarray  # (bins, rows, 3) with bins_first, (2·bins, 3) with ping_layout


def _splat_energy(rows, a, b, e, n_rows, n_bins):
    """Box-splat energies e uniformly over fractional bin spans [a, b) of row ``rows``.

    Returns (n_rows, n_bins). A kink of slope s at fractional position p = i + f adds
    s(1−f) at i+1 and s·f at i+2 of a second-difference array whose cumsum is the cell value.
    """
    return splat_boxes(
        np.asarray(rows, np.int64),
        np.asarray(a, np.float64),
        np.asarray(b, np.float64),
        np.asarray(e, np.float64),
        n_rows,
        n_bins,
    )


SUBBOX_BINS = 2.0  # wide footprints are split into sub-boxes of about this many bins
MAX_SUBBOXES = 32
_NO_LINKS = np.zeros(0, np.bool_)


def _realistic_sigma(t, lab, normal, dirs, origin, seabed, obj_spec, obj_gain) -> None:
    """Seabed hits (label 0): σ/μ from the sediment field (reflectivity 1); object hits
    (label ≥ 1): Lambert term × obj_gain plus the per-facet specular glint. Updates the
    reflectivity and σ/(μ cos θ) rows of :func:`ray_pass`'s terms ``t`` in place."""
    refl, soc, cos_i, r = t[R_REFL], t[R_SOC], t[R_COS], t[R_RANGE]
    if seabed is not None:
        sb = np.flatnonzero(lab == 0)
        if sb.size:
            pts = origin[None, :] + dirs[sb] * r[sb, None]
            s = seabed.sigma_over_mu(pts, normal[sb], dirs[sb])
            refl[sb] = 1.0
            soc[sb] = s / np.maximum(cos_i[sb], 0.02)
    ob = np.flatnonzero(lab >= 1)
    soc[ob] *= obj_gain
    if obj_spec is not None:
        peak, w = obj_spec
        cn = np.minimum(cos_i[ob], 1.0)
        lobe = peak * np.exp(-0.5 * (np.arccos(cn) / w) ** 2)
        soc[ob] += lobe / np.maximum(cn, 0.05)


def form_echo(
    hits: RayHits,
    origin: np.ndarray,
    dirs: np.ndarray,
    d_dirs: np.ndarray,
    gain: np.ndarray,
    rows: np.ndarray,
    n_rows: int,
    n_bins: int,
    r_min: float,
    bin_width: float,
    geom_object_id: np.ndarray,
    geom_reflectivity: np.ndarray,
    alpha_db_m: float,
    specular: tuple[float, float] | None = None,
    footprint_scale: float = 1.0,
    neighbours: np.ndarray | None = None,
    seabed=None,
    object_specular: tuple[float, float] | None = None,
    object_gain: float = 1.0,
    bins_first: bool = False,
    ping_layout: bool = False,
) -> Echo:
    """Bin ray hits into (rows, bins) mean intensity, labels and hit positions.

    dirs (N, 3) unit world ray directions; d_dirs (N, 3) = ∂d/∂θ·Δθ, the direction change to
    the next ray across the sampled fan angle (sets the range footprint); gain (N,)
    SL·b²·ΔΩ·μ (linear); rows (N,) int64 output row per ray; r_min, bin_width in m;
    specular: (σ_s peak / μ, lobe width rad) or None. footprint_scale: each ray's energy
    is spread over ``footprint_scale`` × its footprint (1: footprints tile the range axis;
    2: neighbouring footprints overlap by half, which smooths the steps between coarsely
    spaced rays at the cost of blurring edges by half a footprint).
    neighbours: optional bool (N − 1,): True where rays j and j + 1 are consecutive along
    the sampled fan angle. Where such a neighbour hit the same labelled surface, the footprint side
    towards it reaches their shared cell edge (range interpolated in angle) instead of the local
    plane: for coarse fans (FLS, MSIS) over textured seabeds (ripples) the local normal
    says little about where the next ray lands.
    seabed: optional object with ``sigma_over_mu(points, normals, dirs)`` (e.g.
    :class:`sim.sonar.sediment.SedimentField`): σ/μ of the seabed hits (label 0), replacing
    ``refl·(cos²θ + specular)`` there. object_specular: (σ peak / μ, lobe width rad) of a
    per-facet glint added to object hits (label ≥ 1), or None. object_gain: factor on the
    object hits' Lambert term (a target's own μ over the seabed's ``lambert_mu_db``).

    bins_first: return ``hit_position`` as (bins, rows, 3) (the FLS image layout) instead
    of (rows, bins, 3); ping_layout (two rows): as (2 · bins, 3), row 0 reversed then
    row 1 (the side-scan ping's layout, :class:`sim.sonar.waterfall.SSSPing`).

    Hit positions: cells holding a ray's footprint centre get the energy-weighted mean of
    those rays' hit points; covered cells between centres are linearly interpolated along
    range (their footprint spreads a ray over several cells).
    """
    o = np.asarray(origin, float)
    near_cos = np.inf if specular is None else float(np.cos(min(5.0 * specular[1], np.pi / 2)))
    # two-way absorption exponent (the constant as the array version formed it)
    att_k = float(-0.2 * np.log(10.0) * alpha_db_m)
    t, lab, near, n_obj = ray_pass(
        hits.geom, hits.dist, hits.normal, dirs, d_dirs, geom_object_id, geom_reflectivity,
        near_cos, att_k,
    )  # fmt: skip
    # Lambert μ cos²θ (μ folded into gain) plus the optional specular lobe, per area
    # r²ΔΩ/cosθ: E ∝ (μ cos²θ + σ_s(θ)) / cosθ; the lobe is below e^-12.5 of its peak
    # beyond 5 widths: evaluated only nearer (``near``)
    if specular is not None:  # numpy's arccos and exp, the arithmetic compiled
        spec_peak, spec_w = specular
        cn = lobe_cos(t, near)
        th = np.arccos(cn)
        lobe_exponent(th, float(spec_w))
        np.exp(th, out=th)
        add_lobe(t, near, cn, th, float(spec_peak))
    if seabed is not None or object_specular is not None or object_gain != 1.0:
        _realistic_sigma(t, lab, hits.normal, dirs, o, seabed, object_specular, object_gain)
    np.exp(t[R_ATT], out=t[R_ATT])  # numpy's exp, as the array version, for the same bytes
    use_links = neighbours is not None
    f, link, k, wide, need = footprint_pass(
        gain, t, lab, neighbours if use_links else _NO_LINKS, use_links, float(r_min),
        float(bin_width), n_bins, float(footprint_scale), MIN_EXTENT_BINS, MAX_EXTENT_BINS,
        MAX_EXTENT_FRACTION, SUBBOX_BINS, MAX_SUBBOXES,
    )  # fmt: skip
    if wide.size and use_links:  # log box densities for the sub-box slopes, where read
        dens = f[F_DENS]
        dens[need] = np.log(dens[need])  # numpy's log of an element: that of the whole row
    sub, src = subbox_pass(wide, k, f, link, t[R_RANGE], float(bin_width))
    np.exp(sub[2], out=sub[2])
    if ping_layout and (bins_first or n_rows != 2):
        raise ValueError(
            f"ping_layout needs n_rows = 2 and bins_first False; got n_rows = {n_rows}, "
            f"bins_first = {bins_first}"
        )
    layout = 1 if bins_first else (2 if ping_layout else 0)
    mean, labels, hitpos, start, end = image_pass(
        rows, f, lab, k, sub, src, t[R_RANGE], dirs, o, n_rows, n_bins, layout
    )
    if n_obj:
        r = t[R_RANGE]
        object_pass(mean, labels, hitpos, f, lab, start, end, rows, r, dirs, o, layout)
    # cells labelled −1 are NaN already: the objects only wrote cells they label
    if ping_layout:
        return Echo(mean, labels, hitpos)
    shape = (n_bins, n_rows, 3) if bins_first else (n_rows, n_bins, 3)
    return Echo(mean, labels, hitpos.reshape(shape))

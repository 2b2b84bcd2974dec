"""Seabed backscatter with texture: per-sediment angular laws over a seeded patch field.

Angular law of each sediment (Lurton 2010, *An Introduction to Underwater Acoustics*,
2nd ed., §8.3.4, the "generic" model used for multibeam/side-scan backscatter curves):

    σ(θ) = A · exp(−θ² / (2 w²)) + B · cos^β θ            (θ: incidence from the normal)

a Gaussian (Kirchhoff-like) specular lobe of peak A and width w plus a Lambert-like term
of level B and exponent β (β = 2 is Lambert's law). The constants per sediment are
chosen inside the ranges of the curves reported for 100–700 kHz by Lurton (2010, fig.
8.16) and Jackson & Richardson (2007, *High-Frequency Seafloor Acoustics*, ch. 12–13):
B from −38 dB (mud) to −17 dB (rock); they are starting values for the calibration
(``undersea calibrate``), not measured for a site. The K-distribution shape ν of each
sediment follows the ordering of Lyons & Abraham (1999, JASA 106(3) 1303) for
high-frequency clutter: mud ~ Rayleigh (ν → ∞), sand weakly, gravel and rock strongly
non-Rayleigh.

Low grazing (``low_grazing_knee_deg``, off by default): Lambert's sin² θg (θg grazing) holds
for a sand seabed only above its critical angle (≈ 25–30° for sand, sound-speed ratio
1.1–1.2). Below it the sediment-volume term of the APL-UW high-frequency model (APL-UW
TR 9407, 1994; Jackson & Richardson 2007, ch. 13) fades, because the transmission into
the sediment becomes evanescent, and what is left is interface-roughness scattering,
whose small-roughness perturbation term goes as sin⁴ θg · W(2k cos θg) — faster than
Lambert. One factor per hit models that change of slope with one free angle,

    σ(θg) → σ(θg) / (1 + (sin θk / sin θg)^m),

Lambert above the knee θk, sin^(2+m) θg below it (m = ``low_grazing_exponent``, 4 by
default: the perturbation term's sin⁴). θk is fitted to a recording (``undersea
calibrate --low-grazing``) from passes at different altitudes; it stands for the product
of the law and the vertical beam near horizontal, which a flat seabed cannot separate.

Micro-relief (``micro_slope_deg``, off by default): the seabed below the mesh as
world-fixed square facets of ``micro_slope_cell_m``, each tilted by a Gaussian slope
(tan of the rms angle per axis) that tilts the normal of its hits (the facet model of a
rough surface). The return changes by d ln σ / dθg · δ: little where the law is flat
(steep grazing), a lot below the knee, where σ goes as sin^(2+m) θg — so the seabed turns
spiky (non-Rayleigh, correlated over a facet) at low grazing, as recorded far-range
seabed does.

Low-grazing clutter (``grazing_clutter_deg``, off by default): recorded seabed turns
spikier as the grazing angle falls (shadowing and focusing by relief that the beam sees
nearly edge-on; Lyons & Abraham 1999 report K shapes falling with grazing angle for
high-frequency seafloor clutter). A world-fixed unit-mean gamma texture per clutter cell
whose shape ν follows 1/ν = (sin θc / sin θg)^p: ν = 1 at θc, Rayleigh-like (ν → ∞) well
above it. On the Scotsman's first half (pings 0–229) the tiles' ⟨I²⟩/⟨I⟩² rises from
1.5 at 20–30° grazing to 1.8 at 12–15° and 2.2–2.6 at 10–12°; with the K moment relation
⟨I²⟩/⟨I⟩² = (1 + 1/ν)(1 + 1/L) that gives θc and p (docs/realism.md, "Recorder gain and
low-grazing texture").

The field: a seeded periodic grid (``FIELD_CELL_M``) of smooth Gaussian noise per
sediment; the sediment of a place is the soft arg-max of noise + an offset per sediment,
the offsets fitted so the arg-max areas equal the requested fractions (patches with
sediment boundaries), times a log-normal within-sediment texture and, for
sand, sub-mesh ripples (a sinusoidal slope that tilts the local normal). K clutter: a
world-fixed unit-mean gamma texture per small cell, so it persists across pings.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.ndimage import gaussian_filter
from scipy.special import gammaincinv, ndtri

from sim.sonar.effects import SEDIMENT_NAMES, RealismConfig


@dataclass(frozen=True)
class SedimentLaw:
    """σ(θ) = A exp(−θ²/2w²) + B cos^β θ. a_db, b_db: dB re 1 (m²/m²); width_deg; beta;
    k_shape: K-distribution shape ν of its clutter (inf: Rayleigh)."""

    a_db: float
    width_deg: float
    b_db: float
    beta: float
    k_shape: float

    def sigma(self, incidence: np.ndarray) -> np.ndarray:
        """Backscattering cross-section per unit area per steradian (linear) at incidence
        angle(s) θ (rad from the normal)."""
        th = np.asarray(incidence, float)
        w = np.deg2rad(self.width_deg)
        c = np.clip(np.cos(th), 0.0, 1.0)
        return (
            10.0 ** (self.a_db / 10.0) * np.exp(-0.5 * (th / w) ** 2)
            + 10.0 ** (self.b_db / 10.0) * c**self.beta
        )


SEDIMENTS: dict[str, SedimentLaw] = {
    "mud": SedimentLaw(a_db=-14.0, width_deg=5.0, b_db=-38.0, beta=2.0, k_shape=np.inf),
    "sand": SedimentLaw(a_db=-10.0, width_deg=8.0, b_db=-29.0, beta=2.0, k_shape=20.0),
    "gravel": SedimentLaw(a_db=-10.0, width_deg=14.0, b_db=-22.0, beta=1.5, k_shape=5.0),
    "rock": SedimentLaw(a_db=-8.0, width_deg=25.0, b_db=-17.0, beta=1.2, k_shape=2.0),
}

FIELD_CELL_M = 0.4  # grid of the patch and texture fields, m
FIELD_SIZE = 1024  # cells per side (periodic: the field repeats every 409.6 m)
SOFTMAX_T = 0.12  # softness of sediment boundaries (in units of the noise std)


def _hash_uniform(ix: np.ndarray, iy: np.ndarray, seed: int) -> np.ndarray:
    """A uniform (0, 1) number per integer cell (ix, iy): a splitmix64 hash (vectorised),
    so a world-fixed texture costs no storage and is the same for every sonar."""
    with np.errstate(over="ignore"):
        z = (ix.astype(np.uint64) * np.uint64(0x9E3779B97F4A7C15)) ^ (
            iy.astype(np.uint64) * np.uint64(0xC2B2AE3D27D4EB4F)
        )
        z = z + np.uint64(seed) * np.uint64(0x165667B19E3779F9)
        z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
        z = z ^ (z >> np.uint64(31))
    return ((z >> np.uint64(11)).astype(np.float64) + 0.5) / float(2**53)


@lru_cache(maxsize=4)
def _fields(seed: int, fractions: tuple, patch_px: float, tex_px: float):
    """(N, N, K + 1): K soft sediment weights and a unit-rms texture, both periodic (the
    texture is scaled to dB by the caller, so changing ``texture_db`` rebuilds nothing)."""
    rng = np.random.default_rng(seed)
    shape = (FIELD_SIZE, FIELD_SIZE)
    score = []
    for f in fractions:
        g = gaussian_filter(rng.standard_normal(shape), patch_px, mode="wrap")
        g /= max(float(g.std()), 1e-12)
        score.append(g if f > 0 else np.full(shape, -1e3))
    g = np.stack(score)
    # offsets c_k so that the arg-max areas equal the fractions over the (periodic) field
    target = np.asarray(fractions, float)
    c = np.zeros(len(fractions))
    for _ in range(40):  # fixed-point iterations over four numbers (build time only)
        share = np.bincount(np.argmax(g + c[:, None, None], axis=0).ravel(), minlength=c.size)
        share = share / share.sum()
        c += np.where(
            target > 0, 0.7 * np.log(np.maximum(target, 1e-9) / np.maximum(share, 1e-6)), 0.0
        )
    s = (g + c[:, None, None]) / SOFTMAX_T
    s -= s.max(axis=0, keepdims=True)
    w = np.exp(s)
    w /= w.sum(axis=0, keepdims=True)
    t = gaussian_filter(rng.standard_normal(shape), tex_px, mode="wrap")
    t /= max(float(t.std()), 1e-12)
    return np.ascontiguousarray(np.concatenate([w, t[None]]).transpose(1, 2, 0), np.float32)


def low_grazing_factor(sin_grazing: np.ndarray, knee_deg: float, exponent: float) -> np.ndarray:
    """1 / (1 + (sin θk / sin θg)^m) at sin θg (clipped to [1e-6, 1]); see the module."""
    sg = np.clip(np.asarray(sin_grazing, float), 1e-6, 1.0)
    return 1.0 / (1.0 + (np.sin(np.deg2rad(knee_deg)) / sg) ** exponent)


def low_grazing_texture(sin_grazing: np.ndarray, knee_deg: float, exponent: float) -> np.ndarray:
    """1/ν of the low-grazing clutter, (sin θc / sin θg)^p, at sin θg (clipped to
    [1e-6, 1]); see the module."""
    sg = np.clip(np.asarray(sin_grazing, float), 1e-6, 1.0)
    return (np.sin(np.deg2rad(knee_deg)) / sg) ** exponent


NU_MIN = 0.05  # smallest K shape of the low-grazing clutter (1/ν ≤ 20)
NU_STEPS_PER_OCTAVE = 8  # its shapes on a log grid: ν within ±4.4 % of the law


@lru_cache(maxsize=1)
def _gamma_quantile_table(n: int = 1025) -> np.ndarray:
    """(J, n) unit-mean Γ(ν, 1/ν) quantiles at u = (i + ½)/n for ν_j = ν_min·2^(j/8), from
    ν_min (row 0) to 1000 (built once: a lookup, not gammaincinv per hit)."""
    j = np.arange(int(np.ceil(NU_STEPS_PER_OCTAVE * np.log2(1000.0 / NU_MIN))) + 1)
    nu = NU_MIN * 2.0 ** (j / NU_STEPS_PER_OCTAVE)
    u = (np.arange(n) + 0.5) / n
    return gammaincinv(nu[:, None], u[None, :]) / nu[:, None]


@lru_cache(maxsize=16)
def _gamma_quantiles(shape: float, n: int = 4097) -> np.ndarray:
    """Unit-mean Γ(ν, 1/ν) quantiles at u = (i + ½)/n (inverse-CDF table)."""
    u = (np.arange(n) + 0.5) / n
    return gammaincinv(shape, u) / shape


def bilinear_wrap(grids: np.ndarray, xy: np.ndarray, cell: float) -> np.ndarray:
    """Bilinear interpolation of periodic grids (N, N, C) (row = y, column = x, cell
    ``cell`` m, node (0, 0) at the origin) at world xy (M, 2): (M, C)."""
    n = grids.shape[0]
    c = xy / cell
    f = np.floor(c)
    t = c - f
    i0 = f.astype(np.int64) % n
    i1 = (i0 + 1) % n
    tx, ty = t[:, :1], t[:, 1:]
    flat = grids.reshape(n * n, -1)
    g00 = flat[i0[:, 1] * n + i0[:, 0]]
    g01 = flat[i0[:, 1] * n + i1[:, 0]]
    g10 = flat[i1[:, 1] * n + i0[:, 0]]
    g11 = flat[i1[:, 1] * n + i1[:, 0]]
    return (g00 * (1 - tx) + g01 * tx) * (1 - ty) + (g10 * (1 - tx) + g11 * tx) * ty


class SedimentField:
    """σ/μ of seabed hits from the realism config (see the module docstring).

    ``mu``: the linear Lambert μ folded into the sonars' ray gains (the result is divided
    by it so it replaces ``μ·refl·cos²θ`` in the echo)."""

    def __init__(self, cfg: RealismConfig, mu: float):
        self.cfg = cfg
        self.mu = float(mu)
        self.laws = [SEDIMENTS[n] for n in SEDIMENT_NAMES]
        grids = _fields(
            cfg.sediment_seed,
            cfg.fractions,
            cfg.patch_scale_m / FIELD_CELL_M,
            cfg.texture_scale_m / FIELD_CELL_M,
        )
        self.grids = grids * np.array([1.0, 1.0, 1.0, 1.0, cfg.texture_db], np.float32)
        a = np.deg2rad(cfg.ripple_direction_deg)
        self.ripple_dir = np.array([np.cos(a), np.sin(a), 0.0])
        self.gain = 10.0 ** (cfg.sediment_gain_db / 10.0)

    def lookup(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(M, 4) weights of mud, sand, gravel, rock and (M,) texture (dB) at world xy
        (M, 2) m."""
        g = bilinear_wrap(self.grids, xy, FIELD_CELL_M)
        return g[:, :4], g[:, 4].astype(np.float64)

    def ripple_normal(self, points, normal, sand, texture_db):
        """Normals tilted by sand ripples: slope s = √2·s_rms·cos(k·x + φ) along the
        ripple direction, scaled by the sand weight; φ wanders with the texture field."""
        cfg = self.cfg
        if cfg.ripple_slope <= 0:
            return normal
        k = 2.0 * np.pi / cfg.ripple_wavelength_m
        phase = k * (points @ self.ripple_dir) + 0.8 * texture_db
        s = np.sqrt(2.0) * cfg.ripple_slope * np.cos(phase) * sand
        n = normal - s[:, None] * self.ripple_dir[None, :]
        return n / np.linalg.norm(n, axis=1, keepdims=True)

    def micro_slope_normal(self, xy: np.ndarray, normal: np.ndarray) -> np.ndarray:
        """Normals (M, 3) tilted by the world-fixed facet slopes at world xy (M, 2)."""
        cfg = self.cfg
        if cfg.micro_slope_deg is None or cfg.micro_slope_deg <= 0:
            return normal
        cell = np.floor(xy / cfg.micro_slope_cell_m).astype(np.int64)
        tan_rms = np.tan(np.deg2rad(cfg.micro_slope_deg))
        sx = ndtri(_hash_uniform(cell[:, 0], cell[:, 1], cfg.sediment_seed + 11)) * tan_rms
        sy = ndtri(_hash_uniform(cell[:, 0], cell[:, 1], cfg.sediment_seed + 13)) * tan_rms
        n = normal - np.column_stack([sx, sy, np.zeros_like(sx)])
        return n / np.linalg.norm(n, axis=1, keepdims=True)

    def clutter(self, xy: np.ndarray, k_shape: np.ndarray) -> np.ndarray:
        """World-fixed unit-mean gamma texture of shape ν per clutter cell (1 where ν = ∞)."""
        cell = np.floor(xy / self.cfg.clutter_cell_m).astype(np.int64)
        u = _hash_uniform(cell[:, 0], cell[:, 1], self.cfg.sediment_seed + 7)
        out = np.ones(xy.shape[0])
        for nu in np.unique(k_shape[np.isfinite(k_shape)]):  # ≤ 4 sediments, not per hit
            sel = k_shape == nu
            q = _gamma_quantiles(float(nu))
            out[sel] = q[np.minimum((u[sel] * q.size).astype(np.int64), q.size - 1)]
        return out

    def sigma_over_mu(self, points: np.ndarray, normal: np.ndarray, dirs: np.ndarray):
        """σ/μ (M,) of seabed hits at world points (M, 3) with mesh normals (M, 3) seen
        along ray directions dirs (M, 3)."""
        xy = points[:, :2]
        w, tex = self.lookup(xy)
        n = self.ripple_normal(points, normal, w[:, 1], tex)
        n = self.micro_slope_normal(xy, n)
        cos_i = np.clip(np.abs(np.sum(n * dirs, axis=1)), 0.0, 1.0)
        th = np.arccos(cos_i)
        sig = np.zeros(points.shape[0])
        for j, law in enumerate(self.laws):  # four sediments, not per hit
            sig += w[:, j] * law.sigma(th)
        sig *= 10.0 ** (tex / 10.0) * self.gain
        if self.cfg.low_grazing_knee_deg is not None:
            sig *= low_grazing_factor(
                cos_i, self.cfg.low_grazing_knee_deg, self.cfg.low_grazing_exponent
            )
        if self.cfg.k_clutter:
            shapes = np.array([law.k_shape for law in self.laws])
            sig *= self.clutter(xy, shapes[np.argmax(w, axis=1)])
        if self.cfg.grazing_clutter_deg is not None:
            sin_g = np.abs(np.sum(normal * dirs, axis=1))  # the mesh's grazing, not the facets'
            sig *= self.grazing_clutter(xy, sin_g)
        return sig / self.mu

    def grazing_clutter(self, xy: np.ndarray, sin_grazing: np.ndarray) -> np.ndarray:
        """World-fixed unit-mean gamma texture (per clutter cell) whose shape falls with the
        grazing angle θg: 1/ν = (sin θc / sin θg)^p (θc = grazing_clutter_deg, p =
        grazing_clutter_exponent; see the module). 1 where ν > 1e3 (no texture)."""
        cfg = self.cfg
        inv_nu = low_grazing_texture(
            sin_grazing, cfg.grazing_clutter_deg, cfg.grazing_clutter_exponent
        )
        out = np.ones(xy.shape[0])
        sel = np.flatnonzero(inv_nu > 1e-3)
        if sel.size == 0:
            return out
        cell = np.floor(xy[sel] / cfg.clutter_cell_m).astype(np.int64)
        u = _hash_uniform(cell[:, 0], cell[:, 1], cfg.sediment_seed + 17)
        table = _gamma_quantile_table()
        j = np.rint(-NU_STEPS_PER_OCTAVE * np.log2(inv_nu[sel] * NU_MIN))  # ν = 1 / inv_nu
        j = np.clip(j.astype(np.int64), 0, table.shape[0] - 1)
        i = np.minimum((u * table.shape[1]).astype(np.int64), table.shape[1] - 1)
        out[sel] = table[j, i]
        return out

"""Seabed texture against grazing angle: the K-type clutter that grows as grazing falls.

Per homogeneous seabed tile (the selection of :mod:`slam.realism.statistics`) the
normalised second moment m₂ = ⟨I²⟩/⟨I⟩² and the grazing angle of the tile's centre,
θg = asin(h / r) over a flat seabed (h the ping's altitude, r the slant range, both m).
With K-distributed intensity (texture shape ν, L effective looks; :mod:`slam.realism.kdist`)
m₂ = (1 + 1/ν)(1 + 1/L), so against tiles at steep grazing (θg ≥ ``reference_deg``, where
the texture is negligible) 1/ν(θg) = m₂(θg) / m₂,ref − 1. The fitted law is the
simulator's low-grazing clutter (``grazing_clutter_deg``, :mod:`sim.sonar.sediment`):

    1/ν = (sin θc / sin θg)^p,   i.e.  ln(1/ν) = p·ln sin θc − p·ln sin θg,

a weighted (√tiles) straight-line fit of ln(1/ν) on ln sin θg over 1°-wide bands (2° from
16°) below ``reference_deg`` that hold at least ``min_tiles`` tiles and a positive 1/ν.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from slam.realism.bottom import first_bottom_return
from slam.realism.statistics import (
    RealismConfig,
    _tiles,
    clip_level,
    seabed_mask,
    split_sides,
)

BAND_EDGES_DEG = (3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 18, 20)


@dataclass(frozen=True)
class GrazingTexture:
    """knee_deg θc (1/ν = 1 there), exponent p; bands (lo, hi, tiles, 1/ν) used; m2_ref."""

    knee_deg: float
    exponent: float
    m2_ref: float
    bands: tuple[tuple[float, float, int, float], ...]


def tile_grazing_moments(
    intensity: np.ndarray,
    altitude_m: np.ndarray,
    slant_range_m: float,
    cfg: RealismConfig | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """(grazing angle in degrees, m₂) of every homogeneous seabed tile of both sides of a
    (P, 2S) linear-intensity waterfall; ``altitude_m`` (P,) per ping (the tile's median),
    ``slant_range_m`` of the last sample."""
    cfg = RealismConfig() if cfg is None else cfg
    alt = np.asarray(altitude_m, dtype=np.float64)
    if alt.shape != (intensity.shape[0],):
        raise ValueError(f"altitude_m must have shape ({intensity.shape[0]},), got {alt.shape}")
    if not slant_range_m > 0:
        raise ValueError(f"slant_range_m = {slant_range_m}; must be > 0")
    clip = clip_level(intensity, cfg.full_scale)
    n = cfg.patch
    out_g, out_m = [], []
    for side in split_sides(np.asarray(intensity, dtype=np.float64)):
        p, s = side.shape
        seabed = seabed_mask(first_bottom_return(side), side.shape, cfg.guard)
        tiles = _tiles(side, n)
        ok = _tiles(seabed & (side > 0) & (side < clip), n).all(axis=(1, 2))
        quad = tiles.reshape(-1, 2, n // 2, 2, n // 2).mean(axis=(2, 4)).reshape(-1, 4)
        with np.errstate(divide="ignore", invalid="ignore"):
            spread = 10.0 * np.log10(quad.max(axis=1) / quad.min(axis=1))
        ok &= np.isfinite(spread) & (spread <= cfg.homogeneity_db)
        rows, cols = p // n, s // n
        h = np.nanmedian(alt[: rows * n].reshape(rows, n), axis=1)
        r = (np.arange(cols) * n + 0.5 * n) * slant_range_m / s
        g = np.degrees(np.arcsin(np.clip(h[:, None] / r[None, :], 0.0, 1.0))).ravel()
        t = tiles[ok].reshape(int(ok.sum()), -1)
        out_g.append(g[ok])
        out_m.append((t * t).mean(axis=1) / t.mean(axis=1) ** 2)
    return np.concatenate(out_g), np.concatenate(out_m)


def fit_grazing_texture(
    grazing_deg: np.ndarray,
    m2: np.ndarray,
    reference_deg: float = 20.0,
    min_tiles: int = 5,
) -> GrazingTexture:
    """θc and p of 1/ν = (sin θc / sin θg)^p from per-tile (grazing, m₂) (see the module).
    ValueError when fewer than 3 tiles are at the reference or fewer than 2 bands qualify."""
    g, m = np.asarray(grazing_deg, float), np.asarray(m2, float)
    ref = m[g >= reference_deg]
    if ref.size < 3:
        raise ValueError(
            f"{ref.size} tiles at grazing >= {reference_deg} deg; need 3 for the reference"
        )
    m_ref = float(np.median(ref))
    edges = [e for e in BAND_EDGES_DEG if e <= reference_deg]
    bands, x, y, w = [], [], [], []
    for lo, hi in itertools.pairwise(edges):
        sel = (g >= lo) & (g < hi)
        if sel.sum() < min_tiles:
            continue
        inv_nu = float(np.median(m[sel]) / m_ref - 1.0)
        bands.append((float(lo), float(hi), int(sel.sum()), inv_nu))
        if inv_nu > 0:
            x.append(np.log(np.sin(np.deg2rad(0.5 * (lo + hi)))))
            y.append(np.log(inv_nu))
            w.append(np.sqrt(sel.sum()))
    if len(x) < 2:
        raise ValueError(
            f"{len(x)} grazing bands below {reference_deg} deg with texture above the "
            "reference; need 2 to fit the law"
        )
    slope, icpt = np.polyfit(x, y, 1, w=w)
    p = -float(slope)
    if not p > 0:
        raise ValueError(f"texture does not grow as grazing falls (fitted exponent {p:.2f})")
    knee = float(np.degrees(np.arcsin(min(np.exp(icpt / p), 1.0))))
    return GrazingTexture(knee, p, m_ref, tuple(bands))

"""Side-scan objects larger than a pixel blob: one object assembled across windows, and
its centre estimated from its highlight and its acoustic shadow.

A side-scan highlight is the sonar-facing part of an object: its centroid sits on the
lit side, a different place from each side of a pass (a 20 m wreck's highlight centroid
lies 3-6 m from the hull's centre). The far side of the object is where its shadow
begins, so highlight + shadow bracket the object across track (the classic side-scan
height-from-shadow geometry, e.g. Blondel, *The Handbook of Sidescan Sonar*, 2009,
Sec. 4.4).

Per ping row of an object, with H the altitude and slant ranges r measured along the
ping (flat seabed):

* the shadow spans slant ranges (r_s, r_e]: r_s is the object's top far edge, r_e the
  seabed point its grazing ray reaches. Similar triangles give the top's height above
  the seabed, h = H (1 - r_s / r_e), and its ground range g_far = g(r_e) r_s / r_e
  (g(r) = sqrt(r^2 - H^2));
* the highlight starts at slant r_n: the object's nearest point, at a height between
  the seabed (ground range sqrt(r_n^2 - H^2)) and the top (sqrt(r_n^2 - (H - h)^2),
  layover). The near edge is taken midway, uncertain by a uniform spread over the two;
* the row's across-track centre is (g_near + g_far) / 2, its width g_far - g_near.

The object's centre: width-weighted mean of the rows' centres (across track) and of
their rows (along track); rows without a shadow count for the along-track extent only.
Its covariance (how well the centre is known): the near edge's height ambiguity, the
cells of the highlight and shadow edges and the altitude error, averaged over the shadow
rows as errors common to the object (not divided by the number of rows: one hull shape
biases every row alike), plus the unseen shape: the footprint's centre anywhere within
half the seen width of the seen midpoint (uniform) across track, within a quarter of the
seen length along track (both ends are imaged), and the ends' cells and beam footprint.

Objects longer than a waterfall window: :class:`Part` keeps a region's pixels and row
profile in absolute waterfall coordinates (ping, column), so the windowing
(slam.frontend.sidescan_windows) can hold a part cut by its window's trailing edge and
merge it with its continuation in the next window before estimating the centre.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import cv2
import numpy as np

from slam.frontend.sidescan_prepare import no_return_mask


@dataclass(frozen=True)
class ShadowConfig:
    """shadow_db: a sample this many dB below the seabed level at its range (the
    ``background_percentile`` of its range column over the window) is shadow. A shadow
    is the absence of seabed echo (its level: reverberation and noise, 35-45 dB below
    the seabed on the Scotsman recording and the calibrated presets), while a textured
    seabed's own dark patches reach 8-10 dB below that level (calibrated Scotsman
    texture, 3.8 dB rms at ~1 m, after 3 x 3 looks: 5 % of seabed samples below -7.5 dB,
    1 % below -9.6 dB), so 12 dB keeps textured seabed out and real shadows (a wreck's:
    median -16 dB after 3 x 3 looks; the Scotsman wreck's: -18 dB) in.
    min_shadow_m: shorter dark runs (slant range) are speckle. max_gap_m: lit object
    (deck, superstructure below the segmentation's threshold) allowed between the
    highlight's far edge and the shadow. end_run: the shadow ends where this many
    consecutive samples are not dark. looks, looks_pings: incoherent averaging before the
    test over ``looks`` samples along range x ``looks_pings`` pings. A shadow is a range
    interval of one ping (the geometry of :func:`object_centre`), so the looks are taken
    along range only: an object narrow along track or lying oblique to it (a branch at
    60 degrees to the track moves ~4.6 samples across range per ping) has a shadow that
    shifts from ping to ping, and averaging across pings mixes it with the lit seabed
    beside it (the simulated shipwreck-survey branch's shadow samples: -18.4 dB median
    single-look, -12.0 dB after 3 x 3 looks, -17.1 dB after 5 x 1; docs/detections.md).
    Five looks along range keep the textured seabed's statistics of 3 x 3 (calibrated
    Scotsman texture: 5 % of samples below -7.4 against -7.2 dB, 0.3 % against 0.2 %
    below -12 dB) and shorten a shadow's fully dark core by 4 samples.
    min_shadow_rows: fraction of the object's rows that need a shadow for the centre
    estimate (else the object is a point at its highlight). part_shadow_rows: with
    ``require_shadow`` (slam.frontend.sidescan_windows), fraction of a single segmented
    region's rows that need a shadow for the region to be part of any object (a rock's
    highlight has one on 40-50 % of its rows, its low ends none; a bright texture patch
    borrows a dark patch on a few)."""

    shadow_db: float = 12.0
    min_shadow_m: float = 0.3
    max_gap_m: float = 3.0
    end_run: int = 5
    looks: int = 5
    looks_pings: int = 1
    background_percentile: float = 75.0
    min_shadow_rows: float = 0.2
    part_shadow_rows: float = 1.0 / 3.0

    def __post_init__(self) -> None:
        for name in ("shadow_db", "min_shadow_m", "max_gap_m", "min_shadow_rows"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"ShadowConfig.{name} = {v!r}: must be finite and > 0")
        if not 0 <= self.part_shadow_rows <= 1:
            raise ValueError(
                f"ShadowConfig.part_shadow_rows = {self.part_shadow_rows!r}: allowed [0, 1]"
            )
        if not 0 < self.background_percentile < 100:
            raise ValueError(
                f"ShadowConfig.background_percentile = {self.background_percentile!r}: "
                "allowed (0, 100)"
            )
        for name in ("end_run", "looks", "looks_pings"):
            v = getattr(self, name)
            if not isinstance(v, int) or v < 1:
                raise ValueError(f"ShadowConfig.{name} = {v!r}: must be an integer >= 1")


#: the default shadow settings (simulated and recorded side-scan alike)
SHADOW = ShadowConfig()


def make_shadow_db(
    log_compressed: bool, dynamic_range_db: float, config: ShadowConfig = SHADOW
) -> Callable[[np.ndarray], np.ndarray]:
    """raw window (W, 2S) -> (W, 2S) dB relative to the seabed level at each range.

    The raw display values (log-compressed: linear in dB over ``dynamic_range_db``;
    else linear intensity) are averaged over ``looks`` samples along range x
    ``looks_pings`` pings in linear intensity,
    taken to dB, and the ``background_percentile`` of each range column over the
    window's pings is subtracted (a percentile above the median: a long object's shadow
    may cover half the pings at a range). Samples past the last echo of a ping (no
    data, :func:`no_return_mask`) read 0 dB: never shadow."""

    def rel_db(raw: np.ndarray) -> np.ndarray:
        x = np.asarray(raw, np.float64)
        lin = np.power(10.0, x * (dynamic_range_db / 10.0)) - 1.0 if log_compressed else x
        lin = np.maximum(lin, 0.0)
        if config.looks > 1 or config.looks_pings > 1:
            lin = cv2.blur(lin, (config.looks, config.looks_pings))
        db = 10.0 * np.log10(np.maximum(lin, 1e-12))
        out = db - np.percentile(db, config.background_percentile, axis=0, keepdims=True)
        out[no_return_mask(x)] = 0.0
        return out.astype(np.float32)

    return rel_db


@dataclass
class Part:
    """One segmented region or an object assembled from several, in absolute waterfall
    coordinates: ``pix`` flat indices ping * 2S + column; ``rows`` the ping rows of its
    profile with, per row, the highlight's nearest and farthest sample from nadir
    (``s_near``, ``s_far``) and the shadow's first and last sample (``sh0``, ``sh1``;
    -1 without a shadow). bbox (r0, c0, r1, c1) absolute, ends exclusive; ground (near,
    far) m of the highlight; oid / frac: scoring only (majority object id, labelled
    fraction)."""

    port: bool
    pix: np.ndarray
    rows: np.ndarray
    s_near: np.ndarray
    s_far: np.ndarray
    sh0: np.ndarray
    sh1: np.ndarray
    bbox: tuple[int, int, int, int]
    ground: tuple[float, float]
    oid: int
    frac: float

    @property
    def area_px(self) -> int:
        return int(self.pix.size)


def row_profile(
    rows: np.ndarray,
    cols: np.ndarray,
    port: bool,
    S: int,
    rel_db: np.ndarray | None,
    bin_w: float,
    config: ShadowConfig,
):
    """Per row of a region (window-local ``rows``, ``cols`` of its pixels): (unique rows,
    s_near, s_far, sh0, sh1) as in :class:`Part` (shadow from ``rel_db`` of the window,
    none when it is None)."""
    s = np.where(port, S - 1 - cols, cols - S)
    ur, inv = np.unique(rows, return_inverse=True)
    s_near = np.full(ur.size, S, np.int64)
    s_far = np.full(ur.size, -1, np.int64)
    np.minimum.at(s_near, inv, s)
    np.maximum.at(s_far, inv, s)
    sh0 = np.full(ur.size, -1, np.int64)
    sh1 = np.full(ur.size, -1, np.int64)
    if rel_db is None:
        return ur, s_near, s_far, sh0, sh1
    out = rel_db[ur, S - 1 :: -1] if port else rel_db[ur, S:]  # (n, S) near -> far
    dark = out < -config.shadow_db
    idx = np.arange(S)[None, :]
    gap = max(1, round(config.max_gap_m / bin_w))
    start_ok = dark & (idx > s_far[:, None]) & (idx <= s_far[:, None] + gap)
    has = start_ok.any(axis=1)
    first = np.argmax(start_ok, axis=1)
    # the shadow ends where `end_run` consecutive samples are lit (or at the swath's end)
    k = config.end_run
    lit = (~dark).astype(np.int32)
    c = np.concatenate([np.zeros((lit.shape[0], 1), np.int32), np.cumsum(lit, axis=1)], axis=1)
    run = np.zeros_like(dark)
    run[:, : S - k + 1] = (c[:, k:] - c[:, : S - k + 1]) == k
    stop = run & (idx > first[:, None])
    ends = np.where(stop.any(axis=1), np.argmax(stop, axis=1) - 1, S - 1)
    long_enough = (ends - first + 1) * bin_w >= config.min_shadow_m
    ok = has & long_enough
    sh0[ok], sh1[ok] = first[ok], ends[ok]
    return ur, s_near, s_far, sh0, sh1


def merge_parts(parts: list[Part], S: int) -> Part:
    """One object from several parts (pixels united; a row seen by several parts keeps
    the last part's profile: the newest window saw it with the most context)."""
    if len(parts) == 1:
        return parts[0]
    pix = np.unique(np.concatenate([p.pix for p in parts]))
    rows = np.concatenate([p.rows for p in parts])
    cols = [
        np.concatenate([getattr(p, n) for p in parts]) for n in ("s_near", "s_far", "sh0", "sh1")
    ]
    # keep the last occurrence of each row
    rev = rows[::-1]
    ur, first_rev = np.unique(rev, return_index=True)
    keep = rows.size - 1 - first_rev
    area = np.array([p.area_px for p in parts], float)
    big = parts[int(np.argmax(area))]
    r = pix // (2 * S)
    c = pix % (2 * S)
    return Part(
        parts[0].port,
        pix,
        ur,
        *(x[keep] for x in cols),
        (int(r.min()), int(c.min()), int(r.max()) + 1, int(c.max()) + 1),
        (min(p.ground[0] for p in parts), max(p.ground[1] for p in parts)),
        big.oid,
        float(np.average([p.frac for p in parts], weights=area)),
    )


@dataclass(frozen=True)
class ObjectCentre:
    """An object's centre in waterfall terms: ``row`` (fractional absolute ping row),
    ``ground`` m across track; variances m^2 along track (in rows^2: ``var_rows``) and
    across track (``var_ground``); ``height`` m of its top above the seabed (mean of
    the shadow rows); ``width`` m across track (mean)."""

    row: float
    ground: float
    var_rows: float
    var_ground: float
    height: float
    width: float


def object_centre(
    part: Part,
    slant: np.ndarray,
    altitude: np.ndarray,
    bin_w: float,
    *,
    altitude_sigma: float = 0.1,
    end_sigma_rows: float = 1.0,
    min_shadow_rows: float = 0.2,
) -> ObjectCentre | None:
    """The centre of ``part`` from its highlight and shadow (module docstring), or None
    when fewer than ``min_shadow_rows`` of its rows have a shadow. slant (S,) m, near ->
    far; altitude (n_rows,) m at the part's rows; end_sigma_rows: 1-sigma of each
    along-track end, rows (beam footprint and pixel)."""
    sh = part.sh0 >= 0
    if sh.sum() < max(2, min_shadow_rows * part.rows.size):
        return None
    H = np.asarray(altitude, float)[sh]
    r_n = slant[part.s_near[sh]] - 0.5 * bin_w
    r_s = slant[part.sh0[sh]] - 0.5 * bin_w
    r_e = slant[part.sh1[sh]] + 0.5 * bin_w
    ok = (r_e > H) & (r_n > H) & (r_s > 0)
    if ok.sum() < 2:
        return None
    H, r_n, r_s, r_e = H[ok], r_n[ok], r_s[ok], r_e[ok]
    a = H * r_s / r_e  # top's depth below the sonar: H - h
    g_far = np.sqrt(r_e**2 - H**2) * r_s / r_e
    g_base = np.sqrt(r_n**2 - H**2)
    g_top = np.sqrt(np.maximum(r_n**2 - a**2, 0.0))
    g_near = 0.5 * (g_base + g_top)
    width = np.maximum(g_far - g_near, bin_w)
    mid = 0.5 * (g_near + g_far)
    ground = float(np.average(mid, weights=width))
    # along track: all rows, weighted by their width where known (mean width elsewhere)
    w_all = np.full(part.rows.size, float(width.mean()))
    w_all[np.flatnonzero(sh)[ok]] = width
    row = float(np.average(part.rows.astype(float), weights=w_all))
    # across: the near edge's height ambiguity (uniform), the edge cells, the altitude;
    # the object's shape: its footprint centre anywhere within +-width/2 of the midpoint
    # of what is seen (a listed hull, debris alongside, a buried flank)
    dg_dh = H / np.sqrt(np.maximum(r_e**2 - H**2, 1e-9))
    var_g = (g_top - g_base) ** 2 / 48.0 + bin_w**2 / 24.0 + (dg_dh * altitude_sigma) ** 2
    w_mean = float(np.average(width, weights=width))
    length_rows = float(part.rows.max() - part.rows.min() + 1)
    return ObjectCentre(
        row=row,
        ground=ground,
        var_rows=end_sigma_rows**2 / 2.0 + length_rows**2 / 48.0,
        var_ground=float(np.mean(var_g)) + w_mean**2 / 12.0,
        height=float(np.mean(H - a)),
        width=w_mean,
    )

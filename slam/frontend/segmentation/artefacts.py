"""Image artefacts that are not seabed: burned-in annotations, no-echo areas, and the
first-bottom-return edge of a side-scan waterfall.

* **Burned-in annotations.** Display images exported by survey software carry overlays
  such as the SDVD tiles' "10 M" scale bar: saturated strokes (text, a tick line) drawn
  on a near-black box or flanked by near-black lines. Seabed highlights, even the
  brightest, sit among seabed-level pixels, and an object's highlight has its acoustic
  shadow on one side only. So an annotation stroke pixel is a bright pixel (>= ``bright``)
  whose ``window × window`` neighbourhood is, apart from the bright pixels, mostly
  (>= ``dark_fraction``) near-black (<= ``dark``), with a near-black pixel within
  ``flank_px`` on both sides along its row or along its column. The annotation mask is
  those pixels grown by ``grow_px`` (the box around the text), keeping only grown
  components holding at least ``min_stroke_px`` such pixels: text and tick lines have
  dozens, a target lying in a dark shadow or on a black tile has a few. :func:`mask_annotations` replaces the
  masked pixels with the seabed level (median of the other non-zero pixels), so no
  threshold picks them up and no contrast ring sees them.
* **No-echo areas.** Zero padding of tiles cut at the edge of a swath, and the water
  column before the first bottom return, hold no seabed echo: connected areas of
  near-zero pixels (<= ``level``) of at least ``min_area_px`` pixels. A detection touching
  one is an edge artefact (the bright rim of the first return, or speckle against black)
  rather than an object on the seabed.
* **First-return edge of a waterfall** (:func:`first_return_edge_mask`,
  :func:`first_return_edge_from_altitude`): per ping the first bottom return (the bottom
  track, :mod:`slam.frontend.bottom_track`); everything from nadir to it plus a margin is
  the water column and its edge. The seabed below the sonar returns to both sides at
  once, so a detection with a mirror image on the other side at the same slant range
  (:func:`mirrored_across_nadir`) is that rim too. The pipeline drops detections whose
  centroid falls inside the edge or that are mirrored (:func:`drop_first_return_edge`;
  the Scotsman XTF's symmetric "landmark" at ping 442 is this rim).
* **Display saturation** (:func:`invert_saturated`). A gain-processed display image whose
  seabed level (median non-zero grey level) is near white cannot show a highlight above
  the seabed: an object there appears by its darker parts and its shadow. Inverting the
  data (255 − g on non-zero pixels, zero padding kept at 0) makes those the bright ones.

All masks are ``(H, W)`` bool arrays in image pixels.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import cv2
import numpy as np

from slam.frontend.bottom_track import BottomTrack, fill_track, track_bottom
from slam.io.waterfall import Waterfall

from .image import as_gray8
from .regions import Region, cc_stats

__all__ = [
    "annotation_mask",
    "drop_first_return_edge",
    "first_return_edge_from_altitude",
    "first_return_edge_mask",
    "first_return_samples",
    "invert_saturated",
    "mask_annotations",
    "mirrored_across_nadir",
    "no_echo_mask",
    "regions_outside",
]


def annotation_mask(
    gray8: np.ndarray,
    *,
    bright: int = 200,
    dark: int = 30,
    window: int = 5,
    dark_fraction: float = 0.6,
    flank_px: int = 3,
    min_stroke_px: int = 20,
    grow_px: int = 5,
) -> np.ndarray:
    """Pixels of burned-in annotations (module docstring), ``(H, W)`` bool."""
    if window < 3 or window % 2 == 0:
        raise ValueError(f"window={window!r}: must be an odd integer >= 3 (pixels)")
    if not 0.0 < dark_fraction <= 1.0:
        raise ValueError(f"dark_fraction={dark_fraction!r}: must be in (0, 1]")
    if not 0 <= dark < bright <= 255:
        raise ValueError(f"dark={dark!r}, bright={bright!r}: need 0 <= dark < bright <= 255")
    g = as_gray8(gray8)
    is_bright = (g >= bright).view(np.uint8)
    is_dark = (g <= dark).view(np.uint8)
    k = (window, window)
    n_bright = cv2.boxFilter(is_bright, cv2.CV_32F, k, normalize=False)
    n_dark = cv2.boxFilter(is_dark, cv2.CV_32F, k, normalize=False)
    n_other = window * window - n_bright
    core = is_bright.astype(bool) & (n_other >= window) & (n_dark >= dark_fraction * n_other)
    if core.any():
        core &= _dark_on_both_sides(is_dark, flank_px)
    if not core.any():
        return core
    return _with_enough_strokes(core, grow_px, min_stroke_px)


def _with_enough_strokes(core: np.ndarray, grow_px: int, min_stroke_px: int) -> np.ndarray:
    """``core`` grown by ``grow_px``, keeping only grown components that hold at least
    ``min_stroke_px`` core pixels (text and tick lines; a few bright pixels of a target
    lying in its own shadow are not enough)."""
    size = 2 * int(grow_px) + 1
    grown = cv2.dilate(core.view(np.uint8), np.ones((size, size), np.uint8))
    _n, labels, _stats, _ = cc_stats(grown)
    n_core = np.bincount(labels[core], minlength=int(labels.max()) + 1)
    keep = n_core >= min_stroke_px
    keep[0] = False
    return np.take(keep.view(np.uint8), labels).view(bool)


def _dark_on_both_sides(is_dark: np.ndarray, flank_px: int) -> np.ndarray:
    """Pixels with a dark pixel within ``flank_px`` on both sides along the row or on both
    sides along the column (a stroke drawn on black, not a highlight beside a shadow)."""
    one_side = np.zeros(2 * flank_px + 1, np.float32)
    one_side[:flank_px] = 1.0  # offsets −flank..−1 (filter2D correlates)
    before = one_side[None, :]
    after = one_side[::-1][None, :].copy()
    out = np.zeros(is_dark.shape, bool)
    for kb, ka in ((before, after), (before.T.copy(), after.T.copy())):
        b = cv2.filter2D(is_dark, cv2.CV_8U, kb, borderType=cv2.BORDER_CONSTANT) > 0
        a = cv2.filter2D(is_dark, cv2.CV_8U, ka, borderType=cv2.BORDER_CONSTANT) > 0
        out |= b & a
    return out


def mask_annotations(gray8: np.ndarray, **kwargs) -> tuple[np.ndarray, np.ndarray]:
    """``(image, mask)``: ``gray8`` with its :func:`annotation_mask` pixels set to the
    median of the other non-zero pixels (the seabed level), and that mask."""
    g = as_gray8(gray8)
    mask = annotation_mask(g, **kwargs)
    if not mask.any():
        return g, mask
    rest = g[~mask]
    rest = rest[rest > 0]
    level = int(np.median(rest)) if rest.size else 0
    out = g.copy()
    out[mask] = level
    return out, mask


def no_echo_mask(
    gray8: np.ndarray, *, level: int = 2, min_area_px: int = 200, margin_px: int = 3
) -> np.ndarray:
    """Connected near-zero areas (<= ``level``) of at least ``min_area_px`` pixels, grown
    by ``margin_px`` (module docstring), ``(H, W)`` bool."""
    g = as_gray8(gray8)
    low = (g <= level).view(np.uint8)
    if not low.any():
        return np.zeros(g.shape, bool)
    _n, labels, stats, _ = cc_stats(low)
    big = stats[:, cv2.CC_STAT_AREA] >= min_area_px
    big[0] = False
    if not big.any():
        return np.zeros(g.shape, bool)
    m = np.take(big.view(np.uint8), labels)
    if margin_px > 0:
        size = 2 * int(margin_px) + 1
        m = cv2.dilate(m, np.ones((size, size), np.uint8))
    return m.view(bool)


def invert_saturated(gray8: np.ndarray, level: float) -> tuple[np.ndarray, bool]:
    """``(image, inverted)``: ``gray8`` with its non-zero pixels inverted (255 − g) when
    its seabed level (median non-zero grey level) is >= ``level`` (grey levels 0–255;
    ``inf`` = never), else ``gray8`` itself (module docstring)."""
    if math.isnan(level):
        raise ValueError("invert_saturated: level=nan; need a grey level (0-255) or inf")
    g = as_gray8(gray8)
    nz = g[g > 0]
    if nz.size == 0 or float(np.median(nz)) < level:
        return g, False
    return np.where(g > 0, 255 - g, 0).astype(np.uint8), True


def regions_outside(
    regions: tuple[Region, ...], labels: np.ndarray, suppress: np.ndarray
) -> tuple[Region, ...]:
    """The regions of the label image ``labels`` with no pixel in the bool mask
    ``suppress``."""
    if not regions or not suppress.any():
        return tuple(regions)
    hit = np.zeros(int(labels.max()) + 1, bool)
    hit[np.unique(labels[suppress])] = True
    return tuple(r for r in regions if not hit[r.label])


def first_return_samples(waterfall: Waterfall, track: BottomTrack | None = None) -> np.ndarray:
    """``(pings,)`` first-bottom-return sample index counted from nadir (the same on both
    sides): the bottom track (:func:`slam.frontend.bottom_track.track_bottom`, computed
    when ``track`` is None), pings without a pick interpolated between their neighbours
    (:func:`slam.frontend.bottom_track.fill_track`). Raises ValueError when the waterfall
    has no slant range or no ping has a bottom."""
    bt = track_bottom(waterfall) if track is None else track
    spacing = waterfall.sample_spacing_m()
    return fill_track(bt) / spacing


def first_return_edge_from_altitude(
    altitude_m: np.ndarray,
    slant_m: np.ndarray,
    *,
    margin_fraction: float = 0.3,
    min_margin_samples: int = 8,
) -> np.ndarray:
    """Water column and first-bottom-return edge, ``(pings, 2 × samples)`` bool (port on
    the left, nadir in the middle): True from nadir out to the first return ``r`` (the
    samples whose slant range ``slant_m`` (S,) m, near to far, is below the ping's
    altitude ``altitude_m`` (P,) m) plus ``max(min_margin_samples, margin_fraction · r)``
    samples — the bright rim of the first return is as wide as the beam's footprint at
    nadir, which grows with the altitude, hence a margin proportional to ``r``. Objects
    standing tall (a wreck's superstructure) can return before the seabed does and their
    highlight sits close to the rim, so keep ``margin_fraction`` small."""
    if not 0.0 <= margin_fraction <= 1.0:
        raise ValueError(f"margin_fraction={margin_fraction!r}: must be in [0, 1]")
    if int(min_margin_samples) != min_margin_samples or min_margin_samples < 0:
        raise ValueError(f"min_margin_samples={min_margin_samples!r}: must be an integer >= 0")
    alt = np.asarray(altitude_m, dtype=np.float64).reshape(-1)
    slant = np.asarray(slant_m, dtype=np.float64).reshape(-1)
    first = np.searchsorted(slant, np.where(np.isfinite(alt), alt, 0.0))
    edge = first + np.maximum(min_margin_samples, np.ceil(margin_fraction * first)).astype(int)
    near = np.arange(slant.size)[None, :] < edge[:, None]
    return np.hstack([near[:, ::-1], near])


def first_return_edge_mask(
    waterfall: Waterfall,
    *,
    track: BottomTrack | None = None,
    margin_fraction: float = 0.3,
    min_margin_samples: int = 8,
) -> np.ndarray:
    """:func:`first_return_edge_from_altitude` of a whole waterfall, the first return
    from its bottom track (:func:`first_return_samples`), ``(pings, 2 × samples)`` bool.

    A detection whose centroid lies inside is the edge, not an object on the seabed
    (:func:`drop_first_return_edge`)."""
    s = waterfall.samples_per_side
    first = first_return_samples(waterfall, track)
    return first_return_edge_from_altitude(
        first,
        np.arange(s) + 0.5,
        margin_fraction=margin_fraction,
        min_margin_samples=min_margin_samples,
    )


def mirrored_across_nadir(
    ping: np.ndarray,
    side_port: np.ndarray,
    slant_m: np.ndarray,
    *,
    max_ping_gap: int = 3,
    rel_tol: float = 0.1,
    abs_tol_m: float = 0.1,
) -> np.ndarray:
    """``(n,)`` bool: detections with a partner on the other side within ``max_ping_gap``
    pings whose slant range agrees within ``max(abs_tol_m, rel_tol × range)`` m. The
    seabed below the sonar returns to both sides at once (the first-return rim, the
    surface return and their multiples are mirror images across nadir); an object on the
    seabed is seen on one side only. Inputs are ``(n,)`` arrays: ping index, True for
    port, slant range (m)."""
    k = np.asarray(ping, dtype=np.float64).reshape(-1)
    port = np.asarray(side_port, dtype=bool).reshape(-1)
    r = np.asarray(slant_m, dtype=np.float64).reshape(-1)
    if not k.size == port.size == r.size:
        raise ValueError(f"ping/side/slant sizes {k.size}/{port.size}/{r.size}: must agree")
    other = port[:, None] != port[None, :]
    near = np.abs(k[:, None] - k[None, :]) <= max_ping_gap
    tol = np.maximum(abs_tol_m, rel_tol * np.maximum(r[:, None], r[None, :]))
    same_range = np.abs(r[:, None] - r[None, :]) <= tol
    return (other & near & same_range).any(axis=1)


def drop_first_return_edge(
    detections: Sequence, waterfall: Waterfall, ping_index: np.ndarray | None = None, **kwargs
) -> list:
    """The detections (objects with ``ping``, ``side`` = "port"/"starboard" and
    ``slant_range`` in m) that are neither on the first-return edge of ``waterfall``
    (:func:`first_return_edge_mask`, ``kwargs`` passed on) nor mirrored across nadir
    (:func:`mirrored_across_nadir`). ``ping_index[d.ping]`` is the waterfall row of a
    detection (default: ``d.ping`` itself)."""
    dets = list(detections)
    if not dets:
        return dets
    for d in dets:
        if d.side not in ("port", "starboard"):
            raise ValueError(f"detection side={d.side!r}: need 'port' or 'starboard'")
    mask = first_return_edge_mask(waterfall, **kwargs)
    s = waterfall.samples_per_side
    rows = np.arange(waterfall.n_pings) if ping_index is None else np.asarray(ping_index)
    k = np.array([int(rows[d.ping]) for d in dets])
    port = np.array([d.side == "port" for d in dets])
    slant = np.array([float(d.slant_range) for d in dets])
    rng = np.asarray(waterfall.slant_range_m, dtype=np.float64)[k]
    bad = ~(np.isfinite(rng) & (rng > 0))
    if bad.any():
        i = int(k[np.argmax(bad)])
        raise ValueError(
            f"waterfall.slant_range_m[{i}]={waterfall.slant_range_m[i]!r}: need a range > 0 m"
        )
    sample = np.minimum((slant / rng * s).astype(int), s - 1)
    col = np.where(port, s - 1 - sample, s + sample)
    drop = mask[k, col] | mirrored_across_nadir(k, port, slant)
    return [d for d, x in zip(dets, drop) if not x]

"""Detections a surveyor can trust: the improved Otsu TSM as the first stage, then
artefact suppression, fragment merging and an optional learned second stage.

Stages of :func:`detect` (each switchable in :class:`DetectorConfig`):

1. burned-in annotations masked (:func:`.artefacts.mask_annotations`); optionally the
   tile reduced to its data frame (``frame_padding``: zero padding at its edges is
   outside the image, :func:`.tile_edges.data_frame`) and a display-saturated tile
   inverted (``invert_saturated``, :func:`.artefacts.invert_saturated`);
2. first stage: a threshold method (improved Otsu by default; its threshold optionally
   from part of the tile, ``threshold_pixels``) and Algorithm 2
   (optionally on the binary image reflected across the tile edges, ``reflect_px``:
   :func:`.tile_edges.algorithm2_reflected`);
3. regions touching a no-echo area dropped (:func:`.artefacts.no_echo_mask`);
4. fragments within ``merge_gap_px`` merged into one region (:mod:`.fragments`);
5. geometry (``max_area_px``), local contrast (``min_contrast_db``) and the second stage
   (:class:`RegionClassifier`, a logistic model on eight region features, keeps regions
   with probability >= its ``threshold``);
6. at most ``max_count`` regions per image, the most probable (or largest) first.

Presets (:data:`DETECTORS`): ``"thesis"`` is the reference's method unchanged (improved
Otsu + Algorithm 2, every region a landmark); ``"sdvd-trusted"`` is the full chain with
the second stage trained on the tune half of the SDVD tiles
(``scripts/train_sdvd_stage2.py``); ``"sdvd-saturated"`` the same with display-saturated
tiles (seabed level >= 170) run inverted and the threshold computed without bright
bands of pings at the tile's top or bottom (``threshold_pixels="ping-bands"``);
``"sdvd-rules"`` the same chain with the
contrast test instead of the classifier. Their parameters were chosen on the tune half only
(``docs/detections.md``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace

import numpy as np
from scipy.optimize import minimize

from .artefacts import invert_saturated, mask_annotations, no_echo_mask
from .detection_filters import region_contrast_db, shadow_fraction
from .fragments import merge_fragments
from .image import as_gray8
from .methods import METHODS, SegmentationResult, segment
from .presets import get_preset
from .regions import Region
from .tile_edges import algorithm2_reflected, data_frame, seabed_histogram_mask, shift_regions

__all__ = [
    "DETECTORS",
    "FEATURES",
    "SDVD_STAGE2",
    "THRESHOLD_PIXELS",
    "Candidates",
    "DetectorConfig",
    "RegionClassifier",
    "candidate_regions",
    "detect",
    "fit_region_classifier",
    "get_detector",
    "region_features",
]

#: names of the second stage's region features, in column order
FEATURES: tuple[str, ...] = (
    "log_area_px",
    "log_elongation",
    "contrast_db",
    "shadow_fraction",
    "log_mean_over_seabed",
    "extent",
    "log_seabed_level",
    "contrast_below_best_db",
)


def region_features(
    gray8: np.ndarray, labels: np.ndarray, regions: tuple[Region, ...]
) -> np.ndarray:
    """``(len(regions), 8)`` features (:data:`FEATURES`) of the regions of ``labels``.

    log area (px), log of the major/minor axis ratio (capped at 50), local contrast
    against a 7 px ring (dB), fraction of dark pixels in the 40 px strip behind the region
    on either side (acoustic shadow), log of the region's mean grey level over the seabed
    level (median non-zero grey level of the image, +1 each), area / bounding-box area,
    log of (seabed level + 1), and the region's local contrast minus the highest one
    among ``regions`` (dB, <= 0: a target stands out of its own tile's candidates even
    where the whole tile is dim or display-saturated).
    """
    g = as_gray8(gray8)
    if not regions:
        return np.zeros((0, len(FEATURES)))
    n = int(labels.max()) + 1
    contrast = region_contrast_db(g, labels, 7)
    shadow = shadow_fraction(g, labels, "either", 40, 0.7)
    flat = labels.ravel()
    count = np.maximum(np.bincount(flat, minlength=n), 1)
    mean = np.bincount(flat, weights=g.ravel().astype(np.float64), minlength=n) / count
    nz = g[g > 0]
    seabed = float(np.median(nz)) if nz.size else 0.0
    lab = np.array([r.label for r in regions])
    area = np.array([r.area_px for r in regions], dtype=np.float64)
    elong = np.array([min(r.elongation, 50.0) for r in regions])
    extent = np.array([r.extent for r in regions])
    c = contrast[lab]
    return np.column_stack(
        [
            np.log(area),
            np.log(elong),
            c,
            shadow[lab],
            np.log((mean[lab] + 1.0) / (seabed + 1.0)),
            extent,
            np.full(len(regions), math.log(seabed + 1.0)),
            c - c.max(),
        ]
    )


@dataclass(frozen=True)
class RegionClassifier:
    """Logistic second stage: ``p = 1 / (1 + exp(−(w · (x − mean) / scale + bias)))`` on
    the :data:`FEATURES` ``x`` of a region; regions with ``p >= threshold`` are kept.
    (A study may fit it on more columns; :func:`detect` needs the eight of
    :data:`FEATURES`.)"""

    mean: tuple[float, ...]
    scale: tuple[float, ...]
    weights: tuple[float, ...]
    bias: float
    threshold: float = 0.5

    def __post_init__(self) -> None:
        k = len(self.weights)
        for name in ("mean", "scale"):
            if len(getattr(self, name)) != k:
                raise ValueError(
                    f"RegionClassifier.{name}: {len(getattr(self, name))} values, need one "
                    f"per weight ({k}; the detector's are {', '.join(FEATURES)})"
                )
        if not all(s > 0 for s in self.scale):
            raise ValueError(f"RegionClassifier.scale={self.scale!r}: every value must be > 0")
        if not 0.0 <= self.threshold <= 1.0:
            raise ValueError(f"RegionClassifier.threshold={self.threshold!r}: must be in [0, 1]")

    def probability(self, features: np.ndarray) -> np.ndarray:
        """``(n,)`` probabilities that each region (row of ``features``) is an object."""
        x = np.asarray(features, dtype=np.float64)
        if x.ndim != 2 or x.shape[1] != len(self.weights):
            raise ValueError(f"features {x.shape}: need (n, {len(self.weights)})")
        z = (x - np.asarray(self.mean)) / np.asarray(self.scale)
        return 1.0 / (1.0 + np.exp(-(z @ np.asarray(self.weights) + self.bias)))


def fit_region_classifier(
    features: np.ndarray, is_object: np.ndarray, *, l2: float = 1.0, threshold: float = 0.5
) -> RegionClassifier:
    """Fit the logistic second stage by L2-penalized maximum likelihood (penalty ``l2`` on
    the weights of the standardized features, not on the bias; L-BFGS from zero, so the
    fit is deterministic). ``features``: ``(n, k)`` rows (the detector's are the
    ``k = 8`` of :func:`region_features`); ``is_object``: ``(n,)`` bool labels."""
    x = np.asarray(features, dtype=np.float64)
    y = np.asarray(is_object, dtype=np.float64).ravel()
    if x.ndim != 2 or x.shape[1] < 1 or x.shape[0] != y.size:
        raise ValueError(f"features {x.shape} / is_object {y.shape}: need (n, k) and (n,)")
    if not (0 < y.sum() < y.size):
        raise ValueError("is_object: need both object and non-object regions to fit")
    mean = x.mean(axis=0)
    scale = x.std(axis=0)
    scale[scale <= 0] = 1.0
    z = np.column_stack([(x - mean) / scale, np.ones(len(y))])

    def loss(w: np.ndarray) -> tuple[float, np.ndarray]:
        s = z @ w
        p = 1.0 / (1.0 + np.exp(-s))
        reg = np.r_[w[:-1], 0.0]
        f = float(np.sum(np.logaddexp(0.0, s) - y * s) + 0.5 * l2 * reg @ reg)
        return f, z.T @ (p - y) + l2 * reg

    w = minimize(loss, np.zeros(z.shape[1]), jac=True, method="L-BFGS-B").x
    return RegionClassifier(
        mean=tuple(float(v) for v in mean),
        scale=tuple(float(v) for v in scale),
        weights=tuple(float(v) for v in w[:-1]),
        bias=float(w[-1]),
        threshold=threshold,
    )


#: Second stage trained on the tune half of the SDVD tiles (improved Otsu regions after
#: stages 1–4 of ``"sdvd-trusted"``) by ``scripts/train_sdvd_stage2.py``.
SDVD_STAGE2 = RegionClassifier(
    mean=(4.513293, 0.632526, 1.86834, 0.251753, 0.591564, 0.656232, 4.484185, -1.132743),
    scale=(0.853353, 0.467223, 1.323338, 0.182463, 0.393202, 0.170458, 0.469882, 1.036417),
    weights=(0.897351, -0.737721, 1.187065, -0.599873, -0.383125, -0.088248, -1.047956, 1.255358),
    bias=-3.502066,
    threshold=0.15,
)


#: allowed values of :attr:`DetectorConfig.threshold_pixels`
THRESHOLD_PIXELS: tuple[str, ...] = ("all", "echo", "seabed", "ping-bands", "echo+ping-bands")


_HIST_MASK = {
    "echo": {"strips": "none"},
    "seabed": {"strips": "both"},
    "ping-bands": {"strips": "rows", "drop_no_echo": False},
    "echo+ping-bands": {"strips": "rows"},
}


@dataclass(frozen=True)
class DetectorConfig:
    """The detection chain of :func:`detect` (module docstring).

    method           : first-stage threshold method (one of :data:`.methods.METHODS`).
    preset           : segmentation parameter preset name ("sdvd", "auto", …).
    mask_annotations : mask burned-in annotations before thresholding.
    suppress_no_echo : drop regions touching a no-echo area.
    merge_gap_px     : merge regions at most this many pixels apart (0 = off).
    max_area_px      : drop merged regions larger than this (pixels).
    min_contrast_db  : drop regions with less local contrast (dB; −inf = off).
    classifier       : learned second stage, or None.
    max_count        : keep at most this many regions per image (0 = no limit), highest
                       probability first (largest first without a classifier).
    frame_padding    : run the chain inside the tile's data frame (rows/columns of zero
                       padding at its edges are outside the image, so an object cut by
                       them is cut by the tile edge and not dropped as touching a no-echo
                       area); results are in the whole tile's coordinates.
    reflect_px       : run Algorithm 2 on the binary image extended by this many pixels
                       of reflection across the tile edges (0 = off): a cut object keeps
                       its parts smaller than ``a`` and its holes open to the edge fill.
    invert_saturated : seabed level (median non-zero grey level, 0–255) at or above
                       which the image is display-saturated and the chain runs on it
                       inverted (:func:`.artefacts.invert_saturated`; no-echo areas
                       still from the image itself); ``inf`` = off.
    threshold_pixels : the pixels the first stage's threshold is computed from (it is
                       applied to every pixel): ``"all"`` (the thesis), ``"echo"`` (no-echo
                       areas excluded), ``"seabed"`` (no-echo areas and bright strips
                       along the tile edges excluded), ``"ping-bands"`` (bright bands of
                       pings, rows, at the tile's top or bottom excluded),
                       ``"echo+ping-bands"`` (both); :func:`.tile_edges.seabed_histogram_mask`.
    """

    method: str = "improved-otsu"
    preset: str = "sdvd"
    mask_annotations: bool = True
    suppress_no_echo: bool = True
    merge_gap_px: int = 4
    max_area_px: float = 2000.0
    min_contrast_db: float = -math.inf
    classifier: RegionClassifier | None = SDVD_STAGE2
    max_count: int = 2
    frame_padding: bool = False
    reflect_px: int = 0
    invert_saturated: float = math.inf
    threshold_pixels: str = "all"

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ValueError(f"DetectorConfig.method={self.method!r}: allowed {', '.join(METHODS)}")
        if int(self.merge_gap_px) != self.merge_gap_px or self.merge_gap_px < 0:
            raise ValueError(
                f"DetectorConfig.merge_gap_px={self.merge_gap_px!r}: must be an integer >= 0"
            )
        if not self.max_area_px > 0:
            raise ValueError(f"DetectorConfig.max_area_px={self.max_area_px!r}: must be > 0")
        if math.isnan(self.min_contrast_db):
            raise ValueError("DetectorConfig.min_contrast_db=nan: need a number (dB) or -inf")
        if int(self.max_count) != self.max_count or self.max_count < 0:
            raise ValueError(f"DetectorConfig.max_count={self.max_count!r}: must be >= 0")
        if math.isnan(self.invert_saturated) or self.invert_saturated < 0:
            raise ValueError(
                f"DetectorConfig.invert_saturated={self.invert_saturated!r}: need a grey "
                "level >= 0 or inf"
            )
        if self.threshold_pixels not in THRESHOLD_PIXELS:
            raise ValueError(
                f"DetectorConfig.threshold_pixels={self.threshold_pixels!r}: allowed "
                f"{', '.join(THRESHOLD_PIXELS)}"
            )
        if int(self.reflect_px) != self.reflect_px or self.reflect_px < 0:
            raise ValueError(
                f"DetectorConfig.reflect_px={self.reflect_px!r}: must be an integer >= 0 (pixels)"
            )

    def with_(self, **changes) -> DetectorConfig:
        return replace(self, **changes)


def _select(
    cfg: DetectorConfig, gray8: np.ndarray, labels: np.ndarray, regions: tuple[Region, ...]
) -> tuple[Region, ...]:
    kept = [r for r in regions if r.area_px <= cfg.max_area_px]
    if not kept:
        return ()
    if cfg.min_contrast_db > -math.inf:
        c = region_contrast_db(gray8, labels, 7)
        kept = [r for r in kept if c[r.label] >= cfg.min_contrast_db]
    if not kept:
        return ()
    if cfg.classifier is not None:
        p = cfg.classifier.probability(region_features(gray8, labels, tuple(kept)))
        order = [i for i in np.argsort(-p, kind="stable") if p[i] >= cfg.classifier.threshold]
        kept = [kept[i] for i in order]
    else:
        kept = sorted(kept, key=lambda r: -r.area_px)
    if cfg.max_count > 0:
        kept = kept[: cfg.max_count]
    return tuple(sorted(kept, key=lambda r: r.label))


@dataclass(frozen=True, eq=False)
class Candidates:
    """Stages 1–4 of :func:`detect` on one image: the candidate regions before the
    selection, in the coordinates of the image the chain ran on (the data frame with
    ``frame_padding``, else the whole image).

    first_stage : the first stage's :class:`.methods.SegmentationResult` on ``gray8``.
    gray8       : (h, w) the image the chain ran on (annotations masked; inverted when
                  display-saturated, ``invert_saturated``).
    labels      : (h, w) int32 labels of the merged, not suppressed regions.
    regions     : those regions.
    offset_rc   : (row, col) of ``gray8``'s top-left pixel in the whole image.
    whole       : (H, W) the whole image (annotations masked).
    """

    first_stage: SegmentationResult
    gray8: np.ndarray
    labels: np.ndarray
    regions: tuple[Region, ...]
    offset_rc: tuple[int, int]
    whole: np.ndarray


def candidate_regions(image: np.ndarray, config: DetectorConfig | str) -> Candidates:
    """Stages 1–4 of the detection chain (module docstring) on one image."""
    cfg = get_detector(config) if isinstance(config, str) else config
    if not isinstance(cfg, DetectorConfig):
        raise ValueError(f"config: {type(cfg).__name__} not allowed; need DetectorConfig or a name")
    g = as_gray8(image)
    if cfg.mask_annotations:
        g, _ = mask_annotations(g)
    rows, cols = (
        data_frame(g) if cfg.frame_padding else (slice(0, g.shape[0]), slice(0, g.shape[1]))
    )
    gc = np.ascontiguousarray(g[rows, cols]) if g[rows, cols].shape != g.shape else g
    data = gc
    if cfg.invert_saturated < math.inf:
        gc, _ = invert_saturated(gc, cfg.invert_saturated)
    ne = hist_mask = None
    if cfg.threshold_pixels != "all":
        ne = no_echo_mask(data)
        hist_mask = seabed_histogram_mask(gc, ne, **_HIST_MASK[cfg.threshold_pixels])
    res = segment(gc, cfg.method, get_preset(cfg.preset, gc.shape), hist_mask=hist_mask)
    labels, regions = res.labels, res.regions
    if cfg.reflect_px and res.binary.any():  # a cut part < a px leaves no region
        p = res.params
        regions, labels = algorithm2_reflected(
            res.binary, p.a_px, p.dilate_iterations, int(cfg.reflect_px)
        )
        res = replace(res, mask=labels > 0)
    relabel = False
    if cfg.suppress_no_echo and regions:
        ne = no_echo_mask(data) if ne is None else ne
        if ne.any():
            bad = np.zeros(int(labels.max()) + 1, bool)
            bad[np.unique(labels[ne])] = True
            labels = np.where(bad[labels], 0, labels).astype(np.int32)
            relabel = True
    if cfg.merge_gap_px or relabel:
        regions, labels = merge_fragments(labels, int(cfg.merge_gap_px))
    return Candidates(res, gc, labels, regions, (rows.start, cols.start), g)


def detect(image: np.ndarray, config: DetectorConfig | str = "sdvd-trusted") -> SegmentationResult:
    """Run the detection chain on one image; the result's ``regions``/``labels`` are the
    merged regions, its ``landmarks`` the detections, its ``gray8`` the image the first
    stage saw (annotations masked), all in the whole image's coordinates."""
    cfg = get_detector(config) if isinstance(config, str) else config
    t0 = time.perf_counter()
    c = candidate_regions(image, cfg)
    res, labels, regions = c.first_stage, c.labels, c.regions
    landmarks = _select(cfg, c.gray8, labels, regions)
    if c.gray8.shape != c.whole.shape:
        res, labels, regions, landmarks = _to_whole_tile(c, landmarks)
    timing = dict(res.timing_s)
    timing["total"] = time.perf_counter() - t0
    return replace(res, regions=regions, labels=labels, landmarks=landmarks, timing_s=timing)


def _to_whole_tile(c: Candidates, landmarks: tuple[Region, ...]):
    """The chain's outputs from the data frame back to the whole image ``c.whole``."""
    dr, dc = c.offset_rc
    h, w = c.gray8.shape

    def whole(a: np.ndarray) -> np.ndarray:
        out = np.zeros(c.whole.shape, a.dtype)
        out[dr : dr + h, dc : dc + w] = a
        return out

    res = c.first_stage
    res = replace(res, binary=whole(res.binary), mask=whole(res.mask), gray8=c.whole)
    return (
        res,
        whole(c.labels),
        shift_regions(c.regions, dr, dc),
        shift_regions(landmarks, dr, dc),
    )


#: Named detection chains (module docstring).
DETECTORS: dict[str, DetectorConfig] = {
    "thesis": DetectorConfig(
        preset="auto",
        mask_annotations=False,
        suppress_no_echo=False,
        merge_gap_px=0,
        max_area_px=math.inf,
        classifier=None,
        max_count=0,
    ),
    "sdvd-trusted": DetectorConfig(),
    "sdvd-saturated": DetectorConfig(invert_saturated=170.0, threshold_pixels="ping-bands"),
    "sdvd-rules": DetectorConfig(classifier=None, min_contrast_db=2.0, max_count=1),
}


def get_detector(name: str) -> DetectorConfig:
    """The detection chain called ``name`` (:data:`DETECTORS`)."""
    try:
        return DETECTORS[name]
    except KeyError:
        raise ValueError(f"detector={name!r}: unknown; allowed: {', '.join(DETECTORS)}") from None

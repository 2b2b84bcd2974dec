"""The improved Otsu TSM (thesis ch. 3.3) and the four baseline threshold methods.

Every method thresholds an 8-bit grey image, then runs the same morphology chain
(Algorithm 2, :mod:`.regions`) and the same optional :class:`~.regions.RegionFilter`, and
returns a :class:`SegmentationResult`.

Improved Otsu TSM, step by step:

1. power-law transform ``y = c·x^r`` (c = 0.1, r = 1.415) of the 8-bit image (eq. 3.11);
2. traditional Otsu threshold ``T`` of ``y`` (OpenCV's ``THRESH_OTSU`` formula on the
   histogram that step 5 reuses, :func:`.kernels.otsu_from_hist`); ``b = y > T``;
3. Canny edges of ``b`` (Algorithm 1): 3×3 Gaussian with σ = 0.5, 2×2 finite-difference
   gradient, non-maximum suppression and hysteresis with the high threshold a fraction
   of the maximum gradient magnitude (MATLAB's ``edge(b, 'canny', high)`` convention) and
   low = 0.4 × high (OpenCV ``Canny`` on the supplied gradients);
4. ``N_a`` = number of Canny contours with area < ``a`` px. The thesis traces contours with
   MATLAB's Moore-neighbour boundary tracing, which yields one outer contour per
   8-connected edge object; the area of that object (its pixel count, as ``regionprops``
   reports it) is compared with ``a``. So ``N_a`` = number of 8-connected components of
   the edge map with fewer than ``a`` pixels (OpenCV ``connectedComponentsWithStats``);
5. if ``N_a > N_max``: ``T*`` = Otsu over grey levels ``[T+1, 255]`` only (eqs. 3.1–3.10,
   :func:`.otsu.otsu_threshold_hist`); else ``T* = T``. The segmentation is ``y > T*``.

Baselines (on the 8-bit image without the power law, as the thesis compares them):

* ``otsu``    — traditional Otsu (OpenCV);
* ``local``   — local mean threshold: pixel > mean of its ``b × b`` neighbourhood − offset,
                ``b = 2·floor(min(H, W)/16) + 1`` (MATLAB ``adaptthresh``'s default size),
                offset 0 grey levels (box filter from OpenCV);
* ``isodata`` — iterative intermeans threshold (scikit-image ``threshold_isodata``);
* ``kapur``   — maximum entropy threshold (:mod:`.kapur`, written here).

Documented results for degenerate input: an image with a single grey level (after the
conversion of :func:`.image.as_gray8`) has no regions (thresholds = that level, empty
mask); empty, NaN, non-2-D and non-numeric images raise ``ValueError``.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import cv2
import numpy as np

from .image import as_gray8
from .kapur import kapur_threshold_hist
from .kernels import otsu_from_hist, small_edge_objects
from .otsu import gray_histogram, otsu_threshold, otsu_threshold_hist, power_law
from .presets import SegmentationParams, get_preset
from .regions import Region, RegionFilter, cc_stats_compact, extract_regions, morphology_chain

__all__ = [
    "METHODS",
    "SegmentationResult",
    "canny_edges",
    "count_small_contours",
    "improved_otsu",
    "segment",
    "smoothed_gradients",
]

METHODS: tuple[str, ...] = ("improved-otsu", "otsu", "local", "isodata", "kapur")

#: int16 full scale used to hand float gradients to cv2.Canny
_GRAD_SCALE = 16000.0
#: 2 × 2 first finite differences (anchor at the top-left cell pixel)
_DIFF_X = np.array([[-0.5, 0.5], [-0.5, 0.5]], dtype=np.float32)
_DIFF_Y = np.array([[-0.5, -0.5], [0.5, 0.5]], dtype=np.float32)


@dataclass(frozen=True, eq=False)
class SegmentationResult:
    """Output of one segmentation method on one image.

    method           : one of :data:`METHODS`.
    params           : the parameters used (a, N_max, Canny, dilations, power law).
    threshold        : T, 8-bit grey level (improved Otsu: Otsu threshold of the
                       power-law image; ``local``: mean of the local threshold map).
    threshold_star   : T* (equals ``threshold`` except for a re-thresholded improved Otsu).
    retriggered      : N_a > N_max, so the constrained re-threshold ran (improved Otsu only).
    n_small_contours : N_a (−1 for methods that do not compute it).
    binary           : (H, W) bool, the thresholded image before Algorithm 2.
    mask             : (H, W) bool, after Algorithm 2 steps 1–4.
    labels           : (H, W) int32 region labels of ``mask`` (0 = background).
    regions          : all regions of ``mask`` (Algorithm 2 step 5).
    landmarks        : the regions kept by the region filter (= ``regions`` without one).
    timing_s         : seconds per stage ("threshold", "canny", "morphology", "regions",
                       "filter") and "total" (excluding input conversion).
    gray8            : (H, W) uint8, the input as 8-bit grey levels (before the power law).
    """

    method: str
    params: SegmentationParams
    threshold: float
    threshold_star: float
    retriggered: bool
    n_small_contours: int
    binary: np.ndarray = field(repr=False)
    mask: np.ndarray = field(repr=False)
    labels: np.ndarray = field(repr=False)
    regions: tuple[Region, ...]
    landmarks: tuple[Region, ...]
    timing_s: dict[str, float]
    gray8: np.ndarray = field(repr=False)

    @property
    def threshold_normalized(self) -> float:
        """T / 255, as the thesis prints thresholds."""
        return self.threshold / 255.0

    @property
    def threshold_star_normalized(self) -> float:
        """T* / 255."""
        return self.threshold_star / 255.0

    @property
    def centroids_xy(self) -> np.ndarray:
        """(n, 2) landmark centroids (x = column, y = row), pixels."""
        if not self.landmarks:
            return np.zeros((0, 2))
        return np.array([r.centroid_xy for r in self.landmarks], dtype=np.float64)

    def to_dict(self, include_regions: bool = True) -> dict:
        d = {
            "method": self.method,
            "preset": self.params.name,
            "a_px": self.params.a_px,
            "n_max": self.params.n_max,
            "canny_high": self.params.canny_high,
            "threshold": self.threshold,
            "threshold_star": self.threshold_star,
            "threshold_normalized": round(self.threshold_normalized, 4),
            "threshold_star_normalized": round(self.threshold_star_normalized, 4),
            "retriggered": self.retriggered,
            "n_small_contours": self.n_small_contours,
            "n_regions": len(self.regions),
            "n_landmarks": len(self.landmarks),
            "timing_ms": {k: round(v * 1e3, 3) for k, v in self.timing_s.items()},
        }
        if include_regions:
            d["landmarks"] = [r.to_dict() for r in self.landmarks]
        return d


def smoothed_gradients(
    binary: np.ndarray, sigma: float = 0.5, ksize: int = 3
) -> tuple[np.ndarray, np.ndarray]:
    """float32 ``(dx, dy)`` of Algorithm 1 before non-maximum suppression: Gaussian
    ``ksize × ksize`` smoothing with ``sigma`` (replicated border), then the 2 × 2 first
    differences (see :func:`canny_edges`). A bool or 0/1 ``uint8`` mask is smoothed
    straight from its bytes; any other numeric image as float32."""
    f = np.asarray(binary)
    if f.dtype == np.bool_:
        f = f.view(np.uint8)
    elif f.dtype != np.uint8:
        f = f.astype(np.float32)
    k = cv2.getGaussianKernel(ksize, sigma, cv2.CV_32F)
    g = cv2.sepFilter2D(f, cv2.CV_32F, k, k, borderType=cv2.BORDER_REPLICATE)
    dx = cv2.filter2D(g, cv2.CV_32F, _DIFF_X, anchor=(0, 0), borderType=cv2.BORDER_REPLICATE)
    dy = cv2.filter2D(g, cv2.CV_32F, _DIFF_Y, anchor=(0, 0), borderType=cv2.BORDER_REPLICATE)
    return dx, dy


def canny_edges(
    binary: np.ndarray,
    high: float,
    low_ratio: float = 0.4,
    sigma: float = 0.5,
    ksize: int = 3,
) -> np.ndarray:
    """Canny edge map (uint8 0/255) of an image with MATLAB's relative thresholds.

    Algorithm 1 of the thesis: Gaussian ``ksize × ksize`` smoothing with ``sigma``
    (replicated border); the gradient from first finite differences over a 2 × 2 cell,
    ``P = (f[i,j+1] − f[i,j] + f[i+1,j+1] − f[i+1,j]) / 2`` and
    ``Q = (f[i+1,j] − f[i,j] + f[i+1,j+1] − f[i,j+1]) / 2``; then OpenCV's non-maximum
    suppression and hysteresis with thresholds ``high · max|∇|`` and
    ``low_ratio · high · max|∇|`` (L2 magnitude).

    ``binary`` is a bool or 0/1 ``uint8`` mask (any other numeric image is smoothed as
    float32). A mask is smoothed straight from its bytes (separable float32 Gaussian, the
    same kernel and arithmetic as ``cv2.GaussianBlur`` on its float copy) and the scaled
    gradients are rounded by OpenCV (round half to even, as ``numpy.rint``): no
    intermediate float copy of the mask, no NumPy passes.

    (Central differences would put the gradient maximum of a 2-pixel-wide spot on a
    two-pixel plateau, which OpenCV's strict diagonal non-maximum test removes entirely,
    so small speckle would go uncounted; the 2 × 2 difference has no such plateau.)
    """
    dx, dy = smoothed_gradients(binary, sigma, ksize)
    mmax = cv2.minMaxLoc(cv2.magnitude(dx, dy))[1]
    if mmax <= 0.0:
        return np.zeros(dx.shape, dtype=np.uint8)
    scale = _GRAD_SCALE / mmax
    dxi = cv2.multiply(dx, scale, dtype=cv2.CV_16S)
    dyi = cv2.multiply(dy, scale, dtype=cv2.CV_16S)
    return cv2.Canny(dxi, dyi, low_ratio * high * _GRAD_SCALE, high * _GRAD_SCALE, L2gradient=True)


def count_small_contours(edges: np.ndarray, a_px: int) -> int:
    """N_a: number of 8-connected edge objects (one Moore-traced contour each) with fewer
    than ``a_px`` pixels."""
    e = np.asarray(edges)
    if not e.any():
        return 0
    _, _, stats, _ = cc_stats_compact(e if e.dtype == np.uint8 else (e > 0).astype(np.uint8))
    return int(np.count_nonzero(stats[1:, cv2.CC_STAT_AREA] < a_px))


def _above(y: np.ndarray, t: int) -> np.ndarray:
    """``y > t`` as a 0/1 ``uint8`` mask in one OpenCV pass (``y`` uint8)."""
    return cv2.threshold(y, int(t), 1, cv2.THRESH_BINARY)[1]


def _as_bool(mask: np.ndarray) -> np.ndarray:
    """A bool view of a 0/1 ``uint8`` mask (no copy); other masks are compared with 0."""
    return mask.view(np.bool_) if mask.dtype == np.uint8 else mask.astype(bool, copy=False)


def _resolve_params(params: SegmentationParams | str | None, shape) -> SegmentationParams:
    if params is None:
        return get_preset("auto", shape)
    if isinstance(params, str):
        return get_preset(params, shape)
    if not isinstance(params, SegmentationParams):
        raise ValueError(
            f"params: {type(params).__name__} not allowed; need SegmentationParams, a preset name or None"
        )
    return params


def _finish(
    gray8: np.ndarray,
    method: str,
    params: SegmentationParams,
    t: float,
    t_star: float,
    retriggered: bool,
    n_a: int,
    binary: np.ndarray,
    region_filter: RegionFilter | None,
    timing: dict[str, float],
    t_start: float,
) -> SegmentationResult:
    t0 = time.perf_counter()
    mask = morphology_chain(binary, params.a_px, params.dilate_iterations)
    t1 = time.perf_counter()
    regions, labels = extract_regions(mask)
    t2 = time.perf_counter()
    landmarks = regions if region_filter is None else region_filter.apply(regions)
    t3 = time.perf_counter()
    timing.update(morphology=t1 - t0, regions=t2 - t1, filter=t3 - t2, total=t3 - t_start)
    return SegmentationResult(
        method=method,
        params=params,
        threshold=float(t),
        threshold_star=float(t_star),
        retriggered=retriggered,
        n_small_contours=n_a,
        binary=_as_bool(binary),
        mask=_as_bool(mask),
        labels=labels,
        regions=regions,
        landmarks=landmarks,
        timing_s=timing,
        gray8=gray8,
    )


def _constant_result(method, params, gray8, level: int, region_filter) -> SegmentationResult:
    empty = np.zeros(gray8.shape, dtype=bool)
    return SegmentationResult(
        method=method,
        params=params,
        threshold=float(level),
        threshold_star=float(level),
        retriggered=False,
        n_small_contours=0 if method == "improved-otsu" else -1,
        binary=empty,
        mask=empty.copy(),
        labels=np.zeros(gray8.shape, dtype=np.int32),
        regions=(),
        landmarks=(),
        timing_s={"total": 0.0},
        gray8=gray8,
    )


def _histogram(y: np.ndarray, hist_mask: np.ndarray | None) -> np.ndarray:
    """(256,) grey-level counts of ``y``, of the pixels where ``hist_mask`` is True only
    when it is given and selects any (else of every pixel)."""
    if hist_mask is None:
        return gray_histogram(y)
    m = np.asarray(hist_mask)
    if m.shape != y.shape:
        raise ValueError(f"hist_mask: shape {m.shape}, need the image's {y.shape}")
    m = m.astype(bool, copy=False)
    if not m.any():
        return gray_histogram(y)
    return np.bincount(y[m], minlength=256).astype(np.float64)


def improved_otsu(
    image: np.ndarray,
    params: SegmentationParams | str | None = "high-res-sss",
    region_filter: RegionFilter | None = None,
    hist_mask: np.ndarray | None = None,
) -> SegmentationResult:
    """The reference's improved Otsu TSM followed by Algorithm 2 (module docstring).

    Parameters
    ----------
    image  : (H, W) grey image (uint8 as is; other numeric dtypes stretched, see
             :func:`.image.as_gray8`).
    params : :class:`SegmentationParams`, a preset name ("high-res-sss", "low-res-sss",
             "fls", "sdvd", "auto") or None (= "auto", the size rule).
    region_filter : optional landmark filter applied after Algorithm 2.
    hist_mask : optional (H, W) bool: T and T* are computed from the histogram of these
             pixels only (e.g. the seabed without no-echo areas and bright edge strips,
             :func:`.tile_edges.seabed_histogram_mask`); the threshold is applied to the
             whole image. None, or a mask selecting nothing, = every pixel (the thesis).
    """
    gray8 = as_gray8(image)
    p = _resolve_params(params, gray8.shape)
    t_start = time.perf_counter()
    y = power_law(gray8, p.power_c, p.power_r)
    hist = _histogram(y, hist_mask)  # exact counts below 2**24 pixels (float32 in OpenCV)
    occupied = np.flatnonzero(hist)
    lo, hi = int(occupied[0]), int(occupied[-1])
    if lo == hi:
        if hist_mask is None or int(y.min()) == int(y.max()):
            return _constant_result("improved-otsu", p, gray8, lo, region_filter)
        t = lo  # one level on the seabed: everything brighter is above it
    elif hist_mask is not None or y.size < 2**24:
        t = otsu_from_hist(hist)
    else:
        t = otsu_threshold(y)
    b = _above(y, t)
    t1 = time.perf_counter()
    dx, dy = smoothed_gradients(b, p.gaussian_sigma, p.gaussian_ksize)
    n_a = small_edge_objects(dx, dy, p.canny_high, p.canny_low_ratio, p.a_px)
    t2 = time.perf_counter()
    retriggered = n_a > p.n_max
    t_star = t
    if retriggered:
        ts, _ = otsu_threshold_hist(hist, lo=t + 1) if t < 255 else (t, 0.0)
        t_star = ts if ts > t else t
        b = _above(y, t_star)
    t3 = time.perf_counter()
    timing = {"threshold": (t1 - t_start) + (t3 - t2), "canny": t2 - t1}
    return _finish(
        gray8, "improved-otsu", p, t, t_star, retriggered, n_a, b, region_filter, timing, t_start
    )


def _local_threshold(gray8: np.ndarray, offset: float = 0.0) -> tuple[np.ndarray, float]:
    h, w = gray8.shape
    block = 2 * (min(h, w) // 16) + 1
    block = max(block, 3)
    local_mean = cv2.boxFilter(
        gray8, cv2.CV_32F, (block, block), normalize=True, borderType=cv2.BORDER_REPLICATE
    )
    thr = local_mean - np.float32(offset)
    return gray8 > thr, float(thr.mean())


def segment(
    image: np.ndarray,
    method: str = "improved-otsu",
    params: SegmentationParams | str | None = "high-res-sss",
    region_filter: RegionFilter | None = None,
    hist_mask: np.ndarray | None = None,
) -> SegmentationResult:
    """Segment ``image`` with ``method`` (one of :data:`METHODS`), then Algorithm 2 with the
    ``a`` and dilation count of ``params`` and the optional ``region_filter``.
    ``hist_mask`` (improved Otsu and max entropy only; others ignore it): the threshold
    from the histogram of those pixels only (:func:`improved_otsu`)."""
    if method not in METHODS:
        raise ValueError(f"method={method!r}: unknown; allowed: {', '.join(METHODS)}")
    if method == "improved-otsu":
        return improved_otsu(image, params, region_filter, hist_mask)
    gray8 = as_gray8(image)
    p = _resolve_params(params, gray8.shape)
    t_start = time.perf_counter()
    lo, hi = int(gray8.min()), int(gray8.max())
    if lo == hi:
        return _constant_result(method, p, gray8, lo, region_filter)
    if method == "otsu":
        t = float(otsu_threshold(gray8))
        b = gray8 > t
    elif method == "isodata":
        from skimage.filters import threshold_isodata

        t = float(threshold_isodata(gray8))
        b = gray8 > t
    elif method == "kapur":
        t = float(kapur_threshold_hist(_histogram(gray8, hist_mask)))
        b = gray8 > t
    else:  # local
        b, t = _local_threshold(gray8)
    timing = {"threshold": time.perf_counter() - t_start, "canny": 0.0}
    if not math.isfinite(t):
        raise ValueError(f"method {method!r} produced a non-finite threshold {t!r}")
    return _finish(gray8, method, p, t, t, False, -1, b, region_filter, timing, t_start)

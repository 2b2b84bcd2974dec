"""Parameters of the improved Otsu TSM and the reference's presets.

The reference thesis (X. Yuan 2018, ch. 3.3–3.4; ``../shared/REFERENCE.md``) runs the
improved Otsu threshold segmentation method with three parameter sets:

============== ============ ===== ======= ============ ============
preset         image (W×H)  a px  N_max   Canny high   dilations
============== ============ ===== ======= ============ ============
high-res-sss   800 × 800    30    300     0.33         1
low-res-sss    417 × 228    15    100     0.1255       1
fls            1920 × 932   40    600     0.13         2
============== ============ ===== ======= ============ ============

``a`` is the area (pixels) under which a Canny contour counts as a "small bright spot",
``N_max`` the number of such contours above which the threshold is recomputed over
``[T+1, 255]``, the Canny high threshold is relative to the maximum gradient magnitude (the
low threshold is 0.4 × high), and the final dilation with a 3×3 square runs once for SSS
and twice for the FLS image.

Size rule for other images (:func:`params_for_shape`)
------------------------------------------------------
The thesis states that both numbers depend on the image and reports the ratio
``image_area / (a · N_max)`` = 71.1 (800×800), 63.4 (417×228) and 74.6 (1920×932).
Its three values of ``a`` follow the cube root of the image area closely:
``a / area^(1/3)`` = 0.348, 0.329, 0.329. The rule used here is therefore

* ``a = round(0.335 · area^(1/3))`` (reproduces 29, 15, 41 for the three images, i.e. the
  thesis's 30, 15, 40 within one pixel), at least 2;
* ``N_max = round(area / (70 · a))`` (70 ≈ the mean of the three reported ratios), at least 1;
* Canny high threshold 0.13 (the value the thesis uses on its two lower-quality images;
  it is not size dependent), one dilation.

For a 256 × 256 tile this gives ``a = 14``, ``N_max = 67`` (the ``"sdvd"`` preset; it
was derived by the rule, not tuned).

Region filter presets (:data:`REGION_FILTERS`)
----------------------------------------------
A landmark filter after Algorithm 2, applied identically to every method:

* ``"none"`` — keep every region (the thesis's behaviour);
* ``"sdvd"`` — area <= 2000 px, major/minor axis ratio <= 6, at most the 8 largest
  regions per tile. Chosen on the *tune* half of the SDVD effigy tiles only
  (:func:`slam.frontend.segmentation.evaluation.sdvd_split`), as the highest-PPV filter
  of a grid (min area 0–150 px, max area 1000–∞, max elongation 3–∞, max count 1–∞) whose
  improved-Otsu hit rate stayed within 3 points of the unfiltered one; scored on the
  held-out *test* half and on the full set by ``scripts/eval_sdvd.py``.
* ``"sdvd-contrast"`` — the ``"sdvd"`` geometry (area <= 2000 px, elongation <= 6), then
  local contrast >= 2 dB against a 7 px background ring, then at most the 4 largest
  regions (:class:`~.detection_filters.DetectionFilter`);
* ``"sdvd-shadow"`` — the same contrast test plus the acoustic-shadow test: >= 10 % dark
  pixels (below 0.7 × the median non-zero level) in the 40 px strip behind the region on
  its far-range side, either side (tile side unknown); at most the 4 highest-contrast
  regions.
  Both were chosen on the tune half only, by the same rule as ``"sdvd"`` (highest
  improved-Otsu PPV whose hit rate stays within 3 points of the unfiltered one) over a
  grid: contrast 0–3.5 dB, dark ratio 0.5/0.7, shadow fraction 0–0.25, max count 1–8,
  ranking by area or contrast; ties in PPV go to the higher hit rate (tune half, improved
  Otsu: unfiltered hit 0.779; sdvd-contrast 0.765 / PPV 0.383, with contrast ranking
  0.750 / 0.383; sdvd-shadow 0.750 / 0.395, with area ranking 0.735 / 0.385). The old ``"sdvd"`` filter is kept unchanged.

  Measured (``scripts/eval_sdvd.py``, improved Otsu / max entropy, hit · PPV · detections
  per negative tile): ``"sdvd"`` held-out test 0.955·0.142·6.79 / 0.731·0.158·3.98;
  ``"sdvd-contrast"`` test 0.910·0.372·1.69 / 0.731·0.348·1.43, full set
  0.837·0.377·1.88 / 0.667·0.299·2.00; ``"sdvd-shadow"`` test 0.896·0.375·1.69 /
  0.701·0.348·1.43, full 0.822·0.384·1.85 / 0.667·0.314·2.00. The shadow test did not
  generalise: against the contrast test alone with the same (contrast) ranking it lifts
  tune PPV 0.383 -> 0.395 but changes test PPV 0.376 -> 0.375 and costs a hit (test
  0.910 -> 0.896), even with the tile side known from the file name
  (test hit 0.866, PPV 0.365) — the negative tiles hold real objects (logs, rubble,
  wrecks) that cast shadows too. Not adopted (measured, documented in the report):
  masking exact-zero border no-data before thresholding (tune PPV 0.383 -> 0.385, hits
  unchanged: the merged-effigy misses come from bright seabed, not from padding) and a
  minimum area (60 px: tune hit 0.750 -> 0.721 for PPV 0.407).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .detection_filters import DetectionFilter
from .regions import RegionFilter

__all__ = [
    "AREA_CUBE_ROOT_FACTOR",
    "AREA_RATIO",
    "PRESETS",
    "REGION_FILTERS",
    "SegmentationParams",
    "get_preset",
    "get_region_filter",
    "params_for_shape",
]

#: ``a ≈ AREA_CUBE_ROOT_FACTOR · (image area)^(1/3)`` (fit to the thesis's three presets).
AREA_CUBE_ROOT_FACTOR = 0.335
#: ``image_area / (a · N_max)``: the thesis reports 63.4, 71.1 and 74.6; 70 is their mean.
AREA_RATIO = 70.0


@dataclass(frozen=True)
class SegmentationParams:
    """Parameters of the improved Otsu TSM and of the morphology chain (Algorithm 2).

    a_px              : contour / component area threshold a, pixels (N_a counts Canny
                        contours smaller than this; step 1 of Algorithm 2 removes connected
                        components with fewer pixels).
    n_max             : N_max; the constrained re-threshold runs when N_a > N_max.
    canny_high        : Canny high threshold as a fraction of the maximum gradient magnitude
                        (MATLAB ``edge(b, 'canny', high)`` convention), in (0, 1].
    canny_low_ratio   : low threshold = ``canny_low_ratio · canny_high`` (0.4 in the thesis).
    gaussian_sigma    : σ of the 3×3 Gaussian smoothing before the gradient, pixels (0.5).
    gaussian_ksize    : Gaussian kernel size, pixels (3).
    dilate_iterations : number of 3×3 dilations in Algorithm 2 (1 for SSS, 2 for FLS).
    power_c, power_r  : power-law transform ``y = c · x^r`` on 8-bit levels (0.1, 1.415).
    name              : label of the preset ("" for custom values).
    """

    a_px: int = 30
    n_max: int = 300
    canny_high: float = 0.33
    canny_low_ratio: float = 0.4
    gaussian_sigma: float = 0.5
    gaussian_ksize: int = 3
    dilate_iterations: int = 1
    power_c: float = 0.1
    power_r: float = 1.415
    name: str = ""

    def __post_init__(self) -> None:
        if int(self.a_px) != self.a_px or self.a_px < 1:
            raise ValueError(
                f"SegmentationParams.a_px={self.a_px!r}: must be an integer >= 1 (pixels)"
            )
        if int(self.n_max) != self.n_max or self.n_max < 0:
            raise ValueError(f"SegmentationParams.n_max={self.n_max!r}: must be an integer >= 0")
        if not (0.0 < float(self.canny_high) <= 1.0):
            raise ValueError(
                f"SegmentationParams.canny_high={self.canny_high!r}: must be in (0, 1] "
                "(fraction of the maximum gradient magnitude)"
            )
        if not (0.0 < float(self.canny_low_ratio) <= 1.0):
            raise ValueError(
                f"SegmentationParams.canny_low_ratio={self.canny_low_ratio!r}: must be in (0, 1]"
            )
        if not (float(self.gaussian_sigma) > 0.0 and np.isfinite(self.gaussian_sigma)):
            raise ValueError(
                f"SegmentationParams.gaussian_sigma={self.gaussian_sigma!r}: must be > 0 pixels"
            )
        if self.gaussian_ksize < 1 or self.gaussian_ksize % 2 == 0:
            raise ValueError(
                f"SegmentationParams.gaussian_ksize={self.gaussian_ksize!r}: must be an odd integer >= 1"
            )
        if int(self.dilate_iterations) != self.dilate_iterations or self.dilate_iterations < 0:
            raise ValueError(
                f"SegmentationParams.dilate_iterations={self.dilate_iterations!r}: must be an integer >= 0"
            )
        if not (float(self.power_c) > 0.0 and float(self.power_r) > 0.0):
            raise ValueError(
                f"SegmentationParams.power_c={self.power_c!r}, power_r={self.power_r!r}: both must be > 0"
            )

    @property
    def canny_low(self) -> float:
        """Low Canny threshold, fraction of the maximum gradient magnitude."""
        return self.canny_low_ratio * self.canny_high

    def with_(self, **changes) -> SegmentationParams:
        """A copy with some fields changed (validated again)."""
        return replace(self, **changes)


def params_for_shape(shape: tuple[int, ...], *, name: str = "") -> SegmentationParams:
    """Parameters for an image of ``shape = (rows, cols)`` by the size rule (module docstring).

    >>> p = params_for_shape((800, 800)); (p.a_px, p.n_max)
    (29, 315)
    """
    if len(shape) < 2 or int(shape[0]) < 1 or int(shape[1]) < 1:
        raise ValueError(f"shape={tuple(shape)!r}: need (rows >= 1, cols >= 1)")
    area = float(shape[0]) * float(shape[1])
    a = max(2, round(AREA_CUBE_ROOT_FACTOR * area ** (1.0 / 3.0)))
    n_max = max(1, round(area / (AREA_RATIO * a)))
    return SegmentationParams(
        a_px=a,
        n_max=n_max,
        canny_high=0.13,
        dilate_iterations=1,
        name=name or f"size-rule {shape[1]}x{shape[0]}",
    )


#: The reference's three presets plus the size-rule preset for 256×256 SDVD tiles.
PRESETS: dict[str, SegmentationParams] = {
    "high-res-sss": SegmentationParams(
        a_px=30, n_max=300, canny_high=0.33, dilate_iterations=1, name="high-res-sss"
    ),
    "low-res-sss": SegmentationParams(
        a_px=15, n_max=100, canny_high=0.1255, dilate_iterations=1, name="low-res-sss"
    ),
    "fls": SegmentationParams(a_px=40, n_max=600, canny_high=0.13, dilate_iterations=2, name="fls"),
    "sdvd": params_for_shape((256, 256), name="sdvd"),
}


#: Named landmark filters (module docstring).
REGION_FILTERS: dict[str, RegionFilter | DetectionFilter] = {
    "none": RegionFilter(),
    "sdvd": RegionFilter(max_area_px=2000, max_elongation=6.0, max_count=8),
    "sdvd-contrast": DetectionFilter(
        region=RegionFilter(max_area_px=2000, max_elongation=6.0, max_count=4),
        min_contrast_db=2.0,
        annulus_px=7,
        rank_by="area",
    ),
    "sdvd-shadow": DetectionFilter(
        region=RegionFilter(max_area_px=2000, max_elongation=6.0, max_count=4),
        min_contrast_db=2.0,
        annulus_px=7,
        shadow_min_fraction=0.1,
        shadow_length_px=40,
        shadow_dark_ratio=0.7,
        far_range="either",
        rank_by="contrast",
    ),
}


def get_region_filter(name: str) -> RegionFilter | DetectionFilter:
    """The region filter preset called ``name`` ("none", "sdvd", "sdvd-contrast",
    "sdvd-shadow")."""
    try:
        return REGION_FILTERS[name]
    except KeyError:
        raise ValueError(
            f"region filter={name!r}: unknown; allowed: {', '.join(REGION_FILTERS)}"
        ) from None


def get_preset(name: str, shape: tuple[int, ...] | None = None) -> SegmentationParams:
    """The preset called ``name``; ``"auto"`` applies :func:`params_for_shape` to ``shape``."""
    if name == "auto":
        if shape is None:
            raise ValueError("preset 'auto' needs the image shape")
        return params_for_shape(shape, name="auto")
    try:
        return PRESETS[name]
    except KeyError:
        raise ValueError(
            f"preset={name!r}: unknown; allowed: {', '.join([*PRESETS, 'auto'])}"
        ) from None

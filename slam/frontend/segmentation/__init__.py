"""Segmentation and landmarks: the reference's improved Otsu TSM, the baseline threshold
methods, the morphology chain (Algorithm 2), region landmarks, artefact suppression,
fragment merging, the detection chain with its learned second stage, and scoring against
ground truth masks. See the submodules' docstrings for the definitions."""

from .artefacts import (
    annotation_mask,
    drop_first_return_edge,
    first_return_edge_mask,
    mask_annotations,
    no_echo_mask,
)
from .detection_filters import (
    FAR_RANGE,
    DetectionFilter,
    apply_detection_filter,
    region_contrast_db,
    segment_filtered,
    shadow_dark_level,
    shadow_fraction,
)
from .detector import DETECTORS, DetectorConfig, RegionClassifier, detect, get_detector
from .fragments import merge_fragments
from .image import as_gray8, as_mask, load_gray8, load_mask
from .kapur import kapur_entropy_curve, kapur_threshold, kapur_threshold_hist
from .methods import (
    METHODS,
    SegmentationResult,
    canny_edges,
    count_small_contours,
    improved_otsu,
    segment,
)
from .otsu import gray_histogram, otsu_threshold, otsu_threshold_hist, power_law, power_law_lut
from .presets import (
    PRESETS,
    REGION_FILTERS,
    SegmentationParams,
    get_preset,
    get_region_filter,
    params_for_shape,
)
from .regions import (
    Region,
    RegionFilter,
    bridge,
    bridge_lut,
    extract_regions,
    fill_holes,
    morphology_chain,
    remove_small_components,
)
from .scoring import (
    DetectionScore,
    candidate_centroids,
    match_centroids,
    otsu_candidates,
    score_detections,
    score_result,
    sum_scores,
)

__all__ = [
    "DETECTORS",
    "FAR_RANGE",
    "METHODS",
    "PRESETS",
    "REGION_FILTERS",
    "DetectionFilter",
    "DetectionScore",
    "DetectorConfig",
    "Region",
    "RegionClassifier",
    "RegionFilter",
    "SegmentationParams",
    "SegmentationResult",
    "annotation_mask",
    "apply_detection_filter",
    "as_gray8",
    "as_mask",
    "bridge",
    "bridge_lut",
    "candidate_centroids",
    "canny_edges",
    "count_small_contours",
    "detect",
    "drop_first_return_edge",
    "extract_regions",
    "fill_holes",
    "first_return_edge_mask",
    "get_detector",
    "get_preset",
    "get_region_filter",
    "gray_histogram",
    "improved_otsu",
    "kapur_entropy_curve",
    "kapur_threshold",
    "kapur_threshold_hist",
    "load_gray8",
    "load_mask",
    "mask_annotations",
    "match_centroids",
    "merge_fragments",
    "morphology_chain",
    "no_echo_mask",
    "otsu_candidates",
    "otsu_threshold",
    "otsu_threshold_hist",
    "params_for_shape",
    "power_law",
    "power_law_lut",
    "region_contrast_db",
    "remove_small_components",
    "score_detections",
    "score_result",
    "segment",
    "segment_filtered",
    "shadow_dark_level",
    "shadow_fraction",
    "sum_scores",
]

"""Scoring detected landmark centroids against ground-truth object masks.

The reference (thesis tables 3.2–3.9) scores centroids with a confusion matrix

=========================  =========================  ==========================
                           detected as object         not detected as object
=========================  =========================  ==========================
real object                TP                         FN
real non-object            FP                         TN
=========================  =========================  ==========================

and reports FPR = FP / (FP + TN) and PPV (precision) = TP / (TP + FP). Its text does not
say where the non-object centroids counted in TN come from, so this module makes it
explicit:

* **true objects** — the 8-connected components of the ground-truth mask with at least
  ``min_object_px`` pixels, or the whole mask as one object (``merge_components=True``,
  e.g. one effigy per SDVD tile);
* a **detection** (a reported landmark centroid) is a true positive when its pixel lies
  inside a true object's mask, or when it is within ``tol_px`` of a true object's
  centroid; TP counts such detections, FP the others;
* FN = true objects matched by no detection; recall = matched objects / objects;
* **one true positive per object** (:attr:`DetectionScore.ppv_object`): the thesis's
  PPV = TP / (TP + FP) counts every detection inside an object, so an object broken into
  five fragments gives five true positives. ``ppv_object`` = objects hit / detections
  counts at most one per object; every further detection of an already matched object
  counts as false (as in PASCAL VOC detection scoring). :attr:`DetectionScore.ppv` keeps
  the thesis's fragment-counting figure (named ``ppv_fragments`` in the SDVD reports);
* **candidates** — the non-object centroids of the real non-object row. By default (via
  :func:`score_result`) one method-independent pool per image: the 8-connected components
  with at least ``a`` pixels of the *traditional Otsu* segmentation of the same 8-bit
  image (the bright blobs a plain threshold offers as landmark candidates) that do not
  match a true object. TN = candidates − FP, at least 0, so FPR = FP / max(candidates,
  FP): the fraction of background blobs reported as landmarks. Every method is scored
  against the same pool.

Ratios whose denominator is zero are ``None`` (never NaN). Aggregates over many images
sum the counts first (micro average).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from .image import as_mask
from .otsu import otsu_threshold
from .regions import Region, cc_stats

__all__ = [
    "DetectionScore",
    "candidate_centroids",
    "match_centroids",
    "otsu_candidates",
    "score_detections",
    "score_result",
    "sum_scores",
]


def _ratio(num: int, den: int) -> float | None:
    return None if den <= 0 else num / den


@dataclass(frozen=True)
class DetectionScore:
    """Counts of one image (or summed over images) and the reference's rates.

    n_objects    : true objects.
    n_detections : reported landmark centroids (= tp + fp).
    tp, fp, fn, tn : confusion-matrix counts (module docstring); tp and fp count
                   detections, fn counts objects, tn counts background candidates.
    objects_hit  : true objects matched by at least one detection (= n_objects − fn).
    n_images     : images summed into this score.
    images_with_objects, images_hit : images with >= 1 true object, and those of them in
                   which at least one object was hit (the per-tile "found" rate).
    images_with_detections : images with >= 1 detection (for negative tiles: false alarms).
    """

    n_objects: int
    n_detections: int
    tp: int
    fp: int
    fn: int
    tn: int
    objects_hit: int
    n_images: int = 1
    images_with_objects: int = 0
    images_hit: int = 0
    images_with_detections: int = 0

    @property
    def fpr(self) -> float | None:
        """FP / (FP + TN); None when there are no negatives."""
        return _ratio(self.fp, self.fp + self.tn)

    @property
    def ppv(self) -> float | None:
        """TP / (TP + FP) (precision); None without detections."""
        return _ratio(self.tp, self.tp + self.fp)

    @property
    def ppv_object(self) -> float | None:
        """objects hit / detections: at most one true positive per object (module
        docstring); None without detections."""
        return _ratio(self.objects_hit, self.n_detections)

    @property
    def duplicates(self) -> int:
        """Detections inside an object that another detection already matched."""
        return self.tp - self.objects_hit

    @property
    def recall(self) -> float | None:
        """objects hit / objects; None without objects."""
        return _ratio(self.objects_hit, self.n_objects)

    @property
    def hit_rate(self) -> float | None:
        """images with an object hit / images with objects."""
        return _ratio(self.images_hit, self.images_with_objects)

    @property
    def confusion_matrix(self) -> np.ndarray:
        """[[TP, FN], [FP, TN]] (rows: real object / non-object; columns: detected as
        object / not), as the thesis's tables."""
        return np.array([[self.tp, self.fn], [self.fp, self.tn]], dtype=np.int64)

    def to_dict(self) -> dict:
        return {
            "n_images": self.n_images,
            "n_objects": self.n_objects,
            "n_detections": self.n_detections,
            "confusion_matrix": self.confusion_matrix.tolist(),
            "tp": self.tp,
            "fp": self.fp,
            "fn": self.fn,
            "tn": self.tn,
            "fpr": self.fpr,
            "ppv": self.ppv,
            "ppv_object": self.ppv_object,
            "duplicates": self.duplicates,
            "recall": self.recall,
            "images_with_objects": self.images_with_objects,
            "images_hit": self.images_hit,
            "hit_rate": self.hit_rate,
            "images_with_detections": self.images_with_detections,
        }


def _objects(
    truth: np.ndarray, min_object_px: int, merge_components: bool
) -> tuple[np.ndarray, np.ndarray]:
    """(label image with objects 1..K, (K, 2) object centroids (x, y))."""
    t = truth.astype(np.uint8)
    if merge_components:
        if min_object_px > 0 and int(t.sum()) < min_object_px:
            return np.zeros(t.shape, np.int32), np.zeros((0, 2))
        if not t.any():
            return np.zeros(t.shape, np.int32), np.zeros((0, 2))
        rows, cols = np.nonzero(t)
        return t.astype(np.int32), np.array([[cols.mean(), rows.mean()]])
    n, labels, stats, cent = cc_stats(t)
    keep = stats[:, cv2.CC_STAT_AREA] >= max(min_object_px, 1)
    keep[0] = False
    new_id = np.zeros(n, dtype=np.int32)
    new_id[keep] = np.arange(1, int(keep.sum()) + 1, dtype=np.int32)
    return new_id[labels], cent[keep]


def _xy_array(detections) -> np.ndarray:
    if isinstance(detections, np.ndarray):
        xy = np.asarray(detections, dtype=np.float64)
        if xy.size == 0:
            return np.zeros((0, 2))
        if xy.ndim != 2 or xy.shape[1] != 2:
            raise ValueError(f"detections: shape {xy.shape}, need (n, 2) centroids (x, y)")
    else:
        items = list(detections)
        if not items:
            return np.zeros((0, 2))
        if isinstance(items[0], Region):
            xy = np.array([r.centroid_xy for r in items], dtype=np.float64)
        else:
            xy = np.asarray(items, dtype=np.float64).reshape(-1, 2)
    if not np.isfinite(xy).all():
        raise ValueError("detections: centroids must be finite")
    return xy


def match_centroids(
    xy: np.ndarray, object_labels: np.ndarray, object_xy: np.ndarray, tol_px: float
) -> np.ndarray:
    """Object index (0-based) each centroid matches, −1 for none (module rules): inside an
    object's mask first, else the nearest object centroid within ``tol_px``."""
    n = xy.shape[0]
    out = np.full(n, -1, dtype=np.int64)
    if n == 0 or object_xy.shape[0] == 0:
        return out
    h, w = object_labels.shape
    c = np.rint(xy[:, 0]).astype(np.int64)
    r = np.rint(xy[:, 1]).astype(np.int64)
    inside = (r >= 0) & (r < h) & (c >= 0) & (c < w)
    lab = np.zeros(n, dtype=np.int64)
    lab[inside] = object_labels[r[inside], c[inside]]
    out[lab > 0] = lab[lab > 0] - 1
    if tol_px > 0:
        d = np.linalg.norm(xy[:, None, :] - object_xy[None, :, :], axis=2)
        nearest = np.argmin(d, axis=1)
        near_ok = (out < 0) & (d[np.arange(n), nearest] <= tol_px)
        out[near_ok] = nearest[near_ok]
    return out


def score_detections(
    detections: np.ndarray | Sequence[Region] | Iterable,
    truth_mask: np.ndarray,
    *,
    tol_px: float = 0.0,
    candidates: np.ndarray | Sequence[Region] | None = None,
    min_object_px: int = 1,
    merge_components: bool = False,
) -> DetectionScore:
    """Score one image's detected centroids against its ground-truth mask.

    detections : (n, 2) centroids (x = column, y = row) in pixels, or a sequence of
                  :class:`Region`.
    truth_mask : (H, W) bool mask (numbers are thresholded at > 127).
    tol_px     : a detection outside every object's mask still matches an object whose
                 centroid is within this distance, pixels (0 = inside the mask only).
    candidates : centroids of the candidate regions that make up the non-object row
                 (module docstring); None = no candidates (TN = 0).
    """
    if not (np.isfinite(tol_px) and tol_px >= 0):
        raise ValueError(f"tol_px={tol_px!r}: must be a finite distance >= 0 pixels")
    truth = as_mask(truth_mask, name="truth_mask")
    labels, obj_xy = _objects(truth, int(min_object_px), merge_components)
    xy = _xy_array(detections)
    match = match_centroids(xy, labels, obj_xy, tol_px)
    n_obj = obj_xy.shape[0]
    tp = int(np.count_nonzero(match >= 0))
    fp = int(xy.shape[0] - tp)
    hit = np.zeros(n_obj, dtype=bool)
    hit[match[match >= 0]] = True
    objects_hit = int(hit.sum())
    tn = 0
    if candidates is not None:
        cxy = _xy_array(candidates)
        cmatch = match_centroids(cxy, labels, obj_xy, tol_px)
        n_neg = int(np.count_nonzero(cmatch < 0))
        tn = max(n_neg - fp, 0)
    return DetectionScore(
        n_objects=n_obj,
        n_detections=int(xy.shape[0]),
        tp=tp,
        fp=fp,
        fn=n_obj - objects_hit,
        tn=tn,
        objects_hit=objects_hit,
        n_images=1,
        images_with_objects=int(n_obj > 0),
        images_hit=int(objects_hit > 0),
        images_with_detections=int(xy.shape[0] > 0),
    )


def candidate_centroids(binary: np.ndarray, a_px: int) -> np.ndarray:
    """(m, 2) centroids (x, y) of the 8-connected components of ``binary`` with >= a_px pixels."""
    b = np.ascontiguousarray(binary, dtype=np.uint8)
    _n, _, stats, cent = cc_stats(b)
    keep = stats[:, cv2.CC_STAT_AREA] >= max(int(a_px), 1)
    keep[0] = False
    return cent[keep]


def otsu_candidates(gray8: np.ndarray, a_px: int) -> np.ndarray:
    """The default candidate pool: (m, 2) centroids of the components with >= ``a_px``
    pixels of the traditional Otsu segmentation of ``gray8`` (none for a constant image)."""
    if int(gray8.min()) == int(gray8.max()):
        return np.zeros((0, 2))
    return candidate_centroids(gray8 > otsu_threshold(gray8), a_px)


def score_result(
    result,
    truth_mask: np.ndarray,
    *,
    tol_px: float = 0.0,
    min_object_px: int = 1,
    merge_components: bool = False,
) -> DetectionScore:
    """Score a :class:`~.methods.SegmentationResult`: detections = its landmarks,
    candidates = :func:`otsu_candidates` of its input image with its ``a``."""
    truth = as_mask(truth_mask, shape=result.mask.shape, name="truth_mask")
    return score_detections(
        result.landmarks,
        truth,
        tol_px=tol_px,
        candidates=otsu_candidates(result.gray8, result.params.a_px),
        min_object_px=min_object_px,
        merge_components=merge_components,
    )


def sum_scores(scores: Iterable[DetectionScore]) -> DetectionScore:
    """Sum the counts of several images' scores (rates of the sum = micro average)."""
    fields = (
        "n_objects",
        "n_detections",
        "tp",
        "fp",
        "fn",
        "tn",
        "objects_hit",
        "n_images",
        "images_with_objects",
        "images_hit",
        "images_with_detections",
    )
    tot = dict.fromkeys(fields, 0)
    for s in scores:
        for f in fields:
            tot[f] += getattr(s, f)
    return DetectionScore(**tot)

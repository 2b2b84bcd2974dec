"""Evaluation of the segmentation methods on labelled real tiles (SDVD effigy tiles).

Dataset layout (``../shared/data/sdvd``, SDVDs v2.0, ODbL-1.0 / DbCL-1.0)::

    positive/images/<name>.png   positive/masks/<name>.png   (mask > 127 = effigy)
    negative/images/<name>.jpg   negative/masks/<name>.jpg   (empty masks)

Honest tuning split (:func:`sdvd_split`): tiles are grouped by recording — for positives
the side and the timestamp to the minute (``left_202404291018…``; the H and L frequency
channels of one pass share a group), for negatives the leading recording number — and a
group goes to the ``"tune"`` half when ``crc32(group) % 2 == 0``, else to ``"test"``. The
region filter presets ``"sdvd"``, ``"sdvd-contrast"`` and ``"sdvd-shadow"`` were chosen
on the tune half only.

Per tile the effigy counts as one object (the whole mask, ``merge_components=True``); a
detection is a true positive when its centroid pixel lies inside the mask (tolerance 0
px by default: the issue's "a detected centroid inside its mask"). Negative tiles have
no objects, so all their detections are false positives. The reported PPV counts at most
one true positive per effigy (``ppv``: effigies hit / detections); the thesis's
fragment-counting figure is kept beside it as ``ppv_fragments``.
"""

from __future__ import annotations

import os
import re
import time
import zlib
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .detection_filters import DetectionFilter, segment_filtered
from .detector import DetectorConfig, detect
from .image import load_gray8, load_mask
from .presets import SegmentationParams
from .regions import RegionFilter
from .scoring import DetectionScore, score_result, sum_scores

__all__ = [
    "LabelledTile",
    "MethodEvaluation",
    "default_sdvd_dir",
    "evaluate",
    "evaluate_detector",
    "evaluate_run",
    "load_sdvd",
    "sdvd_frequency",
    "sdvd_group",
    "sdvd_split",
]

_IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp")


@dataclass(frozen=True, eq=False)
class LabelledTile:
    """One tile: name, 8-bit grey image, bool truth mask, positive flag, split half."""

    name: str
    image: np.ndarray
    mask: np.ndarray
    positive: bool
    split: str


@dataclass(frozen=True)
class MethodEvaluation:
    """Scores of one method over a set of tiles (counts summed over tiles).

    positives / negatives / all : summed :class:`DetectionScore` over the positive tiles,
    the negative tiles and both.
    hf / lf : summed over the positive tiles of the high- / low-frequency channel
    (:func:`sdvd_frequency`).
    mean_ms : mean segmentation time per tile, ms.
    """

    method: str
    positives: DetectionScore
    negatives: DetectionScore
    all: DetectionScore
    mean_ms: float
    hf: DetectionScore
    lf: DetectionScore

    @property
    def hit_rate(self) -> float | None:
        """Fraction of positive tiles with a detected centroid inside the effigy mask."""
        return self.positives.hit_rate

    @property
    def detections_per_negative(self) -> float | None:
        n = self.negatives.n_images
        return None if n == 0 else self.negatives.n_detections / n

    @property
    def detections_per_positive(self) -> float | None:
        n = self.positives.n_images
        return None if n == 0 else self.positives.n_detections / n

    def to_dict(self) -> dict:
        return {
            "method": self.method,
            "hit_rate": self.hit_rate,
            "hit_rate_hf": self.hf.hit_rate,
            "hit_rate_lf": self.lf.hit_rate,
            "ppv": self.all.ppv_object,
            "ppv_fragments": self.all.ppv,
            "fpr": self.all.fpr,
            "recall": self.positives.recall,
            "detections_per_positive_tile": self.detections_per_positive,
            "detections_per_negative_tile": self.detections_per_negative,
            "negative_tiles_with_detections": self.negatives.images_with_detections,
            "n_positive_tiles": self.positives.n_images,
            "n_negative_tiles": self.negatives.n_images,
            "confusion_matrix": self.all.confusion_matrix.tolist(),
            "mean_ms": round(self.mean_ms, 3),
        }


def default_sdvd_dir() -> Path:
    """The SDVD folder: ``$UNDERSEA_SHARED_DATA/sdvd``, else ``../shared/data/sdvd`` beside
    the clone."""
    env = os.environ.get("UNDERSEA_SHARED_DATA")
    root = Path(env) if env else Path(__file__).resolve().parents[3].parent / "shared" / "data"
    return root / "sdvd"


def sdvd_group(name: str, positive: bool) -> str:
    """Recording group of an SDVD tile file name (module docstring)."""
    if positive:
        m = re.match(r"(left|right)_(\d{12})", name)
        if m is None:
            return name
        return m.group(1) + m.group(2)
    return "neg" + name.split("_")[0]


def sdvd_frequency(name: str) -> str | None:
    """``"H"`` or ``"L"``: the frequency channel of a positive SDVD tile, the letter after
    its 14-digit timestamp (``left_20240429102455H_…`` is high frequency); None when the
    name carries none (the negative tiles)."""
    m = re.match(r"(?:left|right)_\d{14}([HL])", name)
    return None if m is None else m.group(1)


def sdvd_split(name: str, positive: bool) -> str:
    """``"tune"`` or ``"test"``: crc32 of the recording group, even -> tune."""
    return "tune" if zlib.crc32(sdvd_group(name, positive).encode()) % 2 == 0 else "test"


def _image_files(d: Path) -> list[Path]:
    return sorted(p for p in d.iterdir() if p.suffix.lower() in _IMAGE_SUFFIXES)


def load_sdvd(root: str | Path) -> list[LabelledTile]:
    """Load every tile of an SDVD-layout folder (module docstring)."""
    root = Path(root)
    tiles: list[LabelledTile] = []
    for sub, positive in (("positive", True), ("negative", False)):
        img_dir = root / sub / "images"
        if not img_dir.is_dir():
            continue
        for f in _image_files(img_dir):
            img = load_gray8(f)
            if positive:
                mask_path = root / sub / "masks" / f.name
                if not mask_path.is_file():
                    raise ValueError(
                        f"SDVD: no mask {str(mask_path)!r} for positive tile {f.name!r}"
                    )
                mask = load_mask(mask_path, img.shape)
            else:
                mask = np.zeros(img.shape, dtype=bool)
            tiles.append(LabelledTile(f.name, img, mask, positive, sdvd_split(f.name, positive)))
    if not tiles:
        raise ValueError(
            f"SDVD: no tiles under {str(root)!r} (need positive/images, negative/images)"
        )
    return tiles


def _evaluate(tiles, run, method: str, tol_px: float) -> MethodEvaluation:
    pos: list[DetectionScore] = []
    neg: list[DetectionScore] = []
    freq: dict[str | None, list[DetectionScore]] = {"H": [], "L": [], None: []}
    elapsed = 0.0
    n = 0
    for t in tiles:
        t0 = time.perf_counter()
        res = run(t.image)
        elapsed += time.perf_counter() - t0
        n += 1
        sc = score_result(res, t.mask, tol_px=tol_px, merge_components=True)
        (pos if t.positive else neg).append(sc)
        if t.positive:
            freq[sdvd_frequency(t.name)].append(sc)
    sp, sn = sum_scores(pos), sum_scores(neg)
    return MethodEvaluation(
        method=method,
        positives=sp,
        negatives=sn,
        all=sum_scores([sp, sn]),
        mean_ms=1e3 * elapsed / max(n, 1),
        hf=sum_scores(freq["H"]),
        lf=sum_scores(freq["L"]),
    )


def evaluate(
    tiles: Sequence[LabelledTile] | Iterable[LabelledTile],
    method: str,
    params: SegmentationParams | str,
    region_filter: RegionFilter | DetectionFilter | None = None,
    *,
    tol_px: float = 0.0,
) -> MethodEvaluation:
    """Segment every tile with ``method`` and sum the scores (module docstring)."""
    return _evaluate(
        tiles, lambda img: segment_filtered(img, method, params, region_filter), method, tol_px
    )


def evaluate_run(
    tiles: Sequence[LabelledTile] | Iterable[LabelledTile],
    run,
    name: str,
    *,
    tol_px: float = 0.0,
) -> MethodEvaluation:
    """Score ``run(image) -> SegmentationResult`` (its landmarks are the detections) on
    every tile and sum the scores (module docstring); ``name`` labels the result."""
    return _evaluate(tiles, run, name, tol_px)


def evaluate_detector(
    tiles: Sequence[LabelledTile] | Iterable[LabelledTile],
    config: DetectorConfig,
    *,
    tol_px: float = 0.0,
) -> MethodEvaluation:
    """Run the detection chain ``config`` (:func:`.detector.detect`) on every tile and sum
    the scores (module docstring)."""
    return _evaluate(tiles, lambda img: detect(img, config), config.method, tol_px)

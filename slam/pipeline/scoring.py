"""Scoring the pipeline's detections against ground truth (labels and true poses).

Separate from running: :class:`slam.pipeline.SonarSlam` never needs truth. The side-scan
windowing scores its own windows when its pings carry labels (pixel counts in
:class:`~slam.frontend.sidescan_records.WindowResult`); FLS frames and MSIS scans are
scored here with :func:`score_polar`. A detection is a true positive when at least
``tp_fraction`` of its cells carry an object id.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from slam.frontend.polar import PolarResult
from slam.frontend.sidescan_records import Detection
from slam.pipeline.sonar_slam import FrameOutput


@dataclass(frozen=True)
class PolarScore:
    """One polar result scored: its confirmed detections as :class:`Detection` (object id,
    true positive, world position from the true pose), pixels of kept regions on
    seabed (fp_pixels), seabed pixels (bg_pixels) and the object ids imaged."""

    detections: list[Detection]
    fp_pixels: int
    bg_pixels: int
    imaged_ids: set


def score_polar(
    res: PolarResult,
    labels: np.ndarray,
    poses_true: np.ndarray,
    kind: str,
    tp_fraction: float = 0.1,
) -> PolarScore:
    """Score an FLS frame / MSIS scan result against the simulator's ``labels`` (the
    image's shape, object id per cell) and the true poses ``(rows or 1, 3)`` [x, y, yaw]
    (MSIS: one per ping row; FLS: the frame's)."""
    g = res.groups
    lab = np.asarray(labels)
    imaged = set(np.unique(lab[lab > 0]).tolist())
    bg = lab == 0
    bg_pixels = int(np.count_nonzero(bg))
    conf = [d for d in res.detections if d.confirmed]
    if not conf:
        return PolarScore([], 0, bg_pixels, imaged)
    poses_true = np.asarray(poses_true, float).reshape(-1, 3)
    ng = int(g.max())
    top = int(max(lab.max(), 0)) + 1
    obj = lab > 0
    pair = np.bincount(g[obj] * top + lab[obj], minlength=(ng + 1) * top).reshape(ng + 1, top)
    n_cells = np.bincount(g.ravel(), minlength=ng + 1)
    kept = np.isin(g, [d.group for d in conf])
    dets = []
    for d in conf:
        n_obj = int(pair[d.group].sum())
        oid = int(pair[d.group].argmax()) if n_obj else 0
        pt = poses_true[min(d.row, len(poses_true) - 1)] if kind == "msis" else poses_true[0]
        o = d.observation
        a = pt[2] + o.z[1]
        wxy = pt[:2] + o.z[0] * np.array([math.cos(a), math.sin(a)])
        dets.append(
            Detection(
                o.t,
                d.row,
                kind,
                float(o.z[0]),
                float(o.z[0]),
                d.area_px,
                o,
                oid,
                n_obj >= tp_fraction * n_cells[d.group],
                wxy,
            )
        )
    return PolarScore(dets, int(np.count_nonzero(kept & bg)), bg_pixels, imaged)


@dataclass
class DetectionTally:
    """Scores accumulated over a run: (sonar, Detection) pairs, seabed pixels inside
    detections (fp_pixels) and in all (bg_pixels), object ids imaged."""

    detections: list[tuple[str, Detection]] = field(default_factory=list)
    fp_pixels: int = 0
    bg_pixels: int = 0
    imaged_ids: set = field(default_factory=set)

    def add(self, out: FrameOutput) -> None:
        """Score one pipeline output (needs truth in its frames for FLS / MSIS)."""
        if out.window is not None:
            w = out.window
            self.fp_pixels += w.fp_pixels
            self.bg_pixels += w.bg_pixels
            self.imaged_ids |= w.imaged_ids
            self.detections.extend((out.sonar, d) for d in w.detections)
        elif out.polar is not None:
            labels, poses = truth_of(out.frames)
            s = score_polar(out.polar, labels, poses, out.kind)
            self.fp_pixels += s.fp_pixels
            self.bg_pixels += s.bg_pixels
            self.imaged_ids |= s.imaged_ids
            self.detections.extend((out.sonar, d) for d in s.detections)


def truth_of(frames: Sequence) -> tuple[np.ndarray, np.ndarray]:
    """(labels, true poses) of the frames of one polar result: an FLS frame's labels and
    (1, 3) pose, or an MSIS scan's stacked ping labels (pings, bins) and (pings, 3)."""
    missing = [i for i, f in enumerate(frames) if f.truth is None]
    if missing:
        raise ValueError(f"scoring needs ground truth; frames {missing} carry none")
    if len(frames) == 1 and frames[0].geometry.kind == "fls":
        return frames[0].truth.labels, frames[0].truth.pose[None, :]
    return (
        np.stack([f.truth.labels for f in frames]),
        np.array([f.truth.pose for f in frames]),
    )

"""Images and COCO instance annotations from sonar frames and their per-sample labels.

* Display images: 8-bit, ``round(255 · compress_log(I, floor, range))`` with the sonar's
  own display floor and dynamic range (:mod:`sim.sonar.acoustics`), i.e. exactly the
  log-compressed image the simulator shows, quantised.
* Instance masks: one COCO annotation per object id k >= 1 present in an image, mask
  ``labels == k``; RLE by ``pycocotools.mask.encode`` (pixel-exact) or polygons from
  OpenCV contours (approximate). Boxes ``[x, y, w, h]`` are the mask's pixel extent
  (``scipy.ndimage.find_objects``). Samples labelled −2 (other vehicles) get no
  annotation: the simulator does not tell which vehicle they belong to.
* Category ids: position in :data:`CATEGORIES` + 1 (every object class of
  :mod:`sim.world.objects`), the same for every scenario so datasets can be merged.
"""

from __future__ import annotations

import io

import cv2
import numpy as np
from scipy import ndimage

from sim.sonar.acoustics import compress_log
from sim.world.objects import OBJECT_CLASSES

#: COCO categories: (id, name), the object classes of sim.world.objects in their order.
CATEGORIES: tuple[tuple[int, str], ...] = tuple((i + 1, n) for i, n in enumerate(OBJECT_CLASSES))
CATEGORY_ID = {name: cid for cid, name in CATEGORIES}


def coco_categories() -> list[dict]:
    return [{"id": cid, "name": n, "supercategory": "seabed_object"} for cid, n in CATEGORIES]


def display_floor_db(acoustic) -> float:
    """The display floor the simulator uses (``finish_samples``): the configured one, or
    SL + 10·log10 μ − 60 dB."""
    if acoustic.display_floor_db is not None:
        return float(acoustic.display_floor_db)
    return float(acoustic.source_level_db + acoustic.lambert_mu_db - 60.0)


def to_uint8(linear: np.ndarray, acoustic) -> np.ndarray:
    """8-bit display image of a linear intensity image (µPa²)."""
    d = compress_log(
        linear.astype(np.float64), display_floor_db(acoustic), acoustic.dynamic_range_db
    )
    return np.round(d * 255.0).astype(np.uint8)


def png_bytes(img: np.ndarray) -> bytes:
    ok, buf = cv2.imencode(".png", img, [cv2.IMWRITE_PNG_COMPRESSION, 6])
    if not ok:
        raise RuntimeError("PNG encoding failed")
    return buf.tobytes()


def npy_bytes(a: np.ndarray) -> bytes:
    b = io.BytesIO()
    np.save(b, a, allow_pickle=False)
    return b.getvalue()


def fan_view(fls_frame, linear: np.ndarray, labels: np.ndarray):
    """Cartesian fan of an FLS frame: (FanImage of the linear intensity, fan labels).

    The image is the simulator's :func:`sim.sonar.fls.fan_image` (bilinear); the labels
    take the polar cell containing each pixel centre (nearest neighbour, the cell
    convention of ``FLSFrame.cell_of``), −1 outside the fan.
    """
    from dataclasses import replace

    from sim.sonar import fan_image

    fan = fan_image(replace(fls_frame, image=linear))
    H, W = fan.image.shape
    i, j = np.mgrid[0:H, 0:W]
    r, b = fan.pixel_to_range_bearing(i, j)
    ranges, bearings = fls_frame.ranges, fls_frame.bearings
    dr = float(ranges[1] - ranges[0])
    db = float(bearings[0] - bearings[1]) if bearings.size > 1 else 1.0
    row = np.floor((r - (ranges[0] - 0.5 * dr)) / dr).astype(np.int64)
    col = np.round((bearings[0] - b) / db).astype(np.int64)
    ok = fan.mask & (row >= 0) & (row < labels.shape[0]) & (col >= 0) & (col < labels.shape[1])
    out = np.full((H, W), -1, np.int32)
    out[ok] = labels[row[ok], col[ok]]
    return fan, out


def _polygons(mask: np.ndarray) -> list[list[float]]:
    """COCO polygons [x0, y0, x1, y1, ...] of a binary mask: iso-contours at 0.5
    (``skimage.measure.find_contours``), which run along pixel edges, shifted to COCO's
    continuous coordinates (pixel (r, c) covers [c, c+1) x [r, r+1)). Holes are not
    represented (COCO polygons are unions); diagonal edges are cut corner to corner."""
    from skimage import measure

    padded = np.pad(mask.astype(np.float32), 1)
    polys = []
    for c in measure.find_contours(padded, 0.5):
        if len(c) < 3:
            continue
        xy = c[:, ::-1] - 1.0 + 0.5  # (row, col) of the padded image -> (x, y) COCO
        polys.append(np.round(xy.reshape(-1), 3).tolist())
    return polys


def instance_annotations(
    labels: np.ndarray, class_of: dict[int, str], segmentation: str = "rle"
) -> list[dict]:
    """COCO annotations (without ``id``/``image_id``) of every object id k >= 1 in
    ``labels`` (H, W) int: category, segmentation, area (mask pixels), bbox [x, y, w, h]
    (pixels, the mask's extent), iscrowd 0, and ``object_id`` k (the instance's identity
    across frames). Sorted by object id."""
    from pycocotools import mask as mask_utils

    lab = np.where(labels > 0, labels, 0).astype(np.int64)
    slices = ndimage.find_objects(lab)
    anns = []
    for k0, sl in enumerate(slices):
        if sl is None:
            continue
        oid = k0 + 1
        if oid not in class_of:
            raise ValueError(f"label {oid} is not an object of this world (ids {sorted(class_of)})")
        m = np.asfortranarray((labels == oid).astype(np.uint8))
        if segmentation == "rle":
            rle = mask_utils.encode(m)
            seg = {"size": [int(s) for s in rle["size"]], "counts": rle["counts"].decode("ascii")}
        else:
            seg = _polygons(np.ascontiguousarray(m))
        rs, cs = sl
        anns.append(
            {
                "category_id": CATEGORY_ID[class_of[oid]],
                "object_id": oid,
                "segmentation": seg,
                "area": int(m.sum()),
                "bbox": [cs.start, rs.start, cs.stop - cs.start, rs.stop - rs.start],
                "iscrowd": 0,
            }
        )
    return anns

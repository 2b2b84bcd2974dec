"""Input validation and conversion to the 8-bit grey levels the thresholding works on.

Rules (documented results, never silent):

* ``uint8`` 2-D arrays are used as they are.
* other integer and floating 2-D arrays are stretched linearly from their ``[min, max]`` to
  ``[0, 255]`` and rounded (so the power-law transform sees the full 8-bit range, as the
  reference's display images do); a constant array becomes all zeros (it has no regions).
* ``bool``, complex, object or string arrays, arrays that are not 2-D (use
  :func:`load_gray8` or ``cv2.cvtColor`` for colour images), empty arrays and arrays with
  NaN/inf raise ``ValueError`` naming the field.

File loading (:func:`load_gray8`) uses the project reader ``slam.io.images.read_image``
(``cv2.imread(..., IMREAD_UNCHANGED)``; grey-as-colour files read as grey, true colour
converted to luminance): 8-bit files keep their levels exactly, 16-bit files get the same
linear ``[min, max]`` stretch. Masks (:func:`load_mask`) are read with OpenCV directly and
thresholded at > 127 (RGBA masks: the colour channels, alpha ignored).
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

__all__ = ["as_gray8", "as_mask", "load_gray8", "load_mask"]


def as_gray8(image: np.ndarray, name: str = "image") -> np.ndarray:
    """Validate a 2-D image and return it as a C-contiguous ``uint8`` array (see module rules)."""
    arr = np.asarray(image)
    if arr.dtype == bool or arr.dtype.kind not in "uif":
        raise ValueError(
            f"{name}: dtype {arr.dtype} not allowed; need an integer or floating array "
            "(uint8 used as is, others stretched from [min, max] to [0, 255])"
        )
    if arr.ndim != 2:
        raise ValueError(
            f"{name}: shape {arr.shape} is not 2-D; convert colour images to grey first "
            "(slam.frontend.segmentation.load_gray8 or cv2.cvtColor)"
        )
    if arr.size == 0:
        raise ValueError(f"{name}: empty image of shape {arr.shape}")
    if arr.dtype == np.uint8:
        return np.ascontiguousarray(arr)
    if arr.dtype.kind == "f":
        finite = np.isfinite(arr)
        if not finite.all():
            n_bad = int(arr.size - np.count_nonzero(finite))
            raise ValueError(
                f"{name}: {n_bad} of {arr.size} pixels are NaN or infinite; "
                "replace them (e.g. with 0) before segmenting"
            )
    lo = float(arr.min())
    hi = float(arr.max())
    if hi <= lo:
        return np.zeros(arr.shape, dtype=np.uint8)
    scaled = (arr.astype(np.float64) - lo) * (255.0 / (hi - lo))
    return np.ascontiguousarray(np.rint(scaled).astype(np.uint8))


def as_mask(
    mask: np.ndarray, shape: tuple[int, int] | None = None, name: str = "mask"
) -> np.ndarray:
    """A ground-truth mask as a 2-D ``bool`` array: ``bool`` kept, numbers ``> 127`` true
    (the SDVD convention; a 0/1 integer mask therefore has to be passed as ``bool``)."""
    arr = np.asarray(mask)
    if arr.ndim != 2:
        raise ValueError(f"{name}: shape {arr.shape} is not 2-D")
    if shape is not None and arr.shape != tuple(shape):
        raise ValueError(f"{name}: shape {arr.shape} differs from the image shape {tuple(shape)}")
    if arr.dtype == bool:
        return arr
    if arr.dtype.kind not in "uif":
        raise ValueError(f"{name}: dtype {arr.dtype} not allowed (bool or numbers > 127 = object)")
    if arr.dtype.kind == "f" and not np.isfinite(arr).all():
        raise ValueError(f"{name}: contains NaN or infinite values")
    return arr > 127


def _read(path: str | Path) -> np.ndarray:
    p = Path(path)
    if not p.is_file():
        raise ValueError(f"image file {str(p)!r} does not exist")
    img = cv2.imread(str(p), cv2.IMREAD_UNCHANGED)
    if img is None:
        raise ValueError(f"image file {str(p)!r} could not be decoded by OpenCV")
    if img.ndim == 3:
        if img.shape[2] == 1:
            img = img[:, :, 0]
        elif img.shape[2] == 3:
            img = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
        elif img.shape[2] == 4:
            img = cv2.cvtColor(img, cv2.COLOR_BGRA2GRAY)
        else:
            raise ValueError(f"image file {str(p)!r}: {img.shape[2]} channels not supported")
    return img


def load_gray8(path: str | Path) -> np.ndarray:
    """Read an image file (PNG/JPG/TIFF, 8/16-bit, grey or colour) as 2-D ``uint8`` grey:
    8-bit levels unchanged, 16-bit stretched from [min, max] to [0, 255]."""
    from slam.io.images import read_image

    img = read_image(path, color="luminance")
    if img.bit_depth == 8:
        return np.ascontiguousarray(img.to_uint8())
    return as_gray8(img.image, name=str(path))


def load_mask(path: str | Path, shape: tuple[int, int] | None = None) -> np.ndarray:
    """Read a ground-truth mask file (grey, RGB or RGBA) as ``bool``: grey level ``> 127``."""
    img = _read(path)
    if img.dtype == np.uint16:
        img = (img >> 8).astype(np.uint8)
    return as_mask(img, shape, name=str(path))

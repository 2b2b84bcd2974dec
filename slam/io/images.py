"""Image-file reader (PNG, JPG, TIFF; 8- or 16-bit) through OpenCV.

The pipeline works on float32 linear intensity; this reader returns the grey levels
divided by the format's full scale (255 or 65535), so values are in [0, 1] whatever the
bit depth, with the original depth in the metadata.

Memory bound: the image's size is read from the file header (Pillow, no decoding) before
OpenCV decodes it; an image of more than ``max_pixels`` (default ``MAX_IMAGE_PIXELS`` =
40 Mpx: at most ~40 MB decoded 8-bit or 80 MB 16-bit, plus 160 MB as float32) is refused
with a ValueError naming its size and the bound, never decoded into gigabytes. Crop or
tile larger images before reading them (e.g. ``gdal_translate -srcwin``), or pass a larger
``max_pixels`` knowingly.

Colour files: a 3/4-channel file whose colour channels are equal (a grey image saved as
RGB, common for sonar exports) is read as grey. A truly coloured file raises ValueError
unless ``color="luminance"`` asks for OpenCV's BGR→grey conversion.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import PIL.Image

SUPPORTED_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".pgm")
#: Largest image (pixels) read_image decodes unless told otherwise (see module docstring).
MAX_IMAGE_PIXELS = 40_000_000
#: Bytes per pixel at the peak of read_image: decoded ≤ 16-bit grey/colour + float32 copy.
PEAK_BYTES_PER_PIXEL = 4 * 2 + 4


def image_size(path: str | Path) -> tuple[int, int] | None:
    """(height, width) from the file header without decoding the pixels (Pillow), or None
    when Pillow cannot parse the header (OpenCV then reports the file)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", PIL.Image.DecompressionBombWarning)
            with PIL.Image.open(path) as im:
                w, h = im.size
    except PIL.Image.DecompressionBombError as exc:  # > 2 × Pillow's bound (~179 Mpx)
        raise ValueError(f"image {str(path)!r}: too large to read ({exc})") from None
    except (OSError, ValueError):
        return None
    return int(h), int(w)


@dataclass(frozen=True)
class SonarImage:
    """A grey image read from a file.

    image     : (H, W) float32 in [0, 1] (grey level / full scale).
    bit_depth : 8 or 16 (of the file).
    full_scale: 255 or 65535.
    channels  : number of channels in the file (1, 3 or 4).
    source    : path.
    """

    image: np.ndarray
    bit_depth: int
    full_scale: int
    channels: int
    source: str

    def to_uint8(self) -> np.ndarray:
        """The image as 8-bit levels (rounded)."""
        return np.clip(np.rint(self.image * 255.0), 0, 255).astype(np.uint8)


def read_image(
    path: str | Path, *, color: str = "error", max_pixels: int = MAX_IMAGE_PIXELS
) -> SonarImage:
    """Read a PNG/JPG/TIFF file (8- or 16-bit, grey or grey-as-colour) as float32 in [0, 1].

    Parameters
    ----------
    path : image file.
    color : ``"error"`` (default) rejects images whose colour channels differ;
        ``"luminance"`` converts them with ``cv2.cvtColor(..., COLOR_BGR2GRAY)``.
    max_pixels : refuse (before decoding) images with more pixels than this.

    Raises
    ------
    ValueError for a missing/undecodable file, an unsupported suffix or dtype, an empty
    image, an image larger than ``max_pixels``, or a coloured image with ``color="error"``.
    """
    import cv2

    if color not in ("error", "luminance"):
        raise ValueError(f"color must be 'error' or 'luminance', got {color!r}")
    path = Path(path)
    if path.suffix.lower() not in SUPPORTED_SUFFIXES:
        raise ValueError(
            f"image {str(path)!r}: unsupported suffix {path.suffix!r}, allowed {SUPPORTED_SUFFIXES}"
        )
    if not path.is_file():
        raise ValueError(f"image path {str(path)!r} is not a file")
    size = image_size(path)
    if size is not None and size[0] * size[1] > max_pixels:
        h, w = size
        raise ValueError(
            f"image {str(path)!r}: {w} x {h} = {w * h} px exceeds the bound of {max_pixels} px "
            f"(reading it would take ~{w * h * PEAK_BYTES_PER_PIXEL / 2**30:.1f} GiB); crop or "
            "tile it first, or pass a larger max_pixels"
        )
    raw = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if raw is None or raw.size == 0:
        raise ValueError(f"image {str(path)!r}: OpenCV could not decode it (empty or corrupt)")
    if raw.dtype == np.uint8:
        bits, full = 8, 255
    elif raw.dtype == np.uint16:
        bits, full = 16, 65535
    else:
        raise ValueError(
            f"image {str(path)!r}: dtype {raw.dtype} not supported (allowed uint8, uint16)"
        )
    channels = 1 if raw.ndim == 2 else raw.shape[2]
    if raw.ndim == 3:
        bgr = raw[..., :3] if channels >= 3 else raw[..., :1]
        if channels >= 3 and not (
            np.array_equal(bgr[..., 0], bgr[..., 1]) and np.array_equal(bgr[..., 0], bgr[..., 2])
        ):
            if color == "error":
                raise ValueError(
                    f"image {str(path)!r} has {channels} differing colour channels; sonar "
                    "images must be grey (pass color='luminance' to convert)"
                )
            grey = cv2.cvtColor(np.ascontiguousarray(bgr), cv2.COLOR_BGR2GRAY)
        else:
            grey = bgr[..., 0]
    else:
        grey = raw
    img = grey.astype(np.float32) / np.float32(full)
    return SonarImage(
        image=img, bit_depth=bits, full_scale=full, channels=channels, source=str(path)
    )


def as_grey_float(image: np.ndarray, *, name: str = "image") -> np.ndarray:
    """Validate an in-memory image and return it as 2-D float32 (values unchanged).

    Accepts 2-D arrays of bool, integer or float dtype. Rejects empty arrays, non-2-D
    arrays (e.g. 3-channel), complex/object dtypes and non-finite values, each with a
    ValueError naming ``name``.
    """
    a = np.asarray(image)
    if (
        a.dtype == object
        or np.iscomplexobj(a)
        or not (np.issubdtype(a.dtype, np.number) or a.dtype == bool)
    ):
        raise ValueError(f"{name}: dtype {a.dtype} not allowed (need a real numeric array)")
    if a.ndim != 2:
        raise ValueError(
            f"{name}: must be a 2-D grey image, got shape {a.shape} "
            "(convert colour images to grey first)"
        )
    if a.size == 0:
        raise ValueError(f"{name}: empty image, shape {a.shape}")
    a = a.astype(np.float32)
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: contains {int(np.sum(~np.isfinite(a)))} non-finite values")
    return a

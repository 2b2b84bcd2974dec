"""Image-file reader: bit depths, grey-as-colour, bad files."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from slam.io.images import as_grey_float, read_image


def test_8_and_16_bit_scale_to_unit_range(tmp_path, rng):
    """Values come back as level / full scale (255 or 65535), exactly for PNG/TIFF."""
    a8 = rng.integers(0, 256, (20, 30), dtype=np.uint8)
    a16 = rng.integers(0, 65536, (20, 30), dtype=np.uint16)
    cv2.imwrite(str(tmp_path / "a.png"), a8)
    cv2.imwrite(str(tmp_path / "b.tif"), a16)
    cv2.imwrite(str(tmp_path / "c.png"), a16)
    r8 = read_image(tmp_path / "a.png")
    assert r8.bit_depth == 8 and r8.image.dtype == np.float32
    np.testing.assert_allclose(r8.image, a8 / 255.0, atol=1e-7)
    np.testing.assert_array_equal(r8.to_uint8(), a8)
    for name in ("b.tif", "c.png"):
        r = read_image(tmp_path / name)
        assert r.bit_depth == 16
        np.testing.assert_allclose(r.image, a16 / 65535.0, atol=1e-7)


def test_grey_saved_as_rgb_is_grey_but_colour_is_rejected(tmp_path, rng):
    g = rng.integers(0, 256, (10, 12), dtype=np.uint8)
    cv2.imwrite(str(tmp_path / "g.png"), np.dstack([g, g, g]))
    r = read_image(tmp_path / "g.png")
    assert r.channels == 3
    np.testing.assert_allclose(r.image, g / 255.0, atol=1e-7)
    c = np.dstack([g, g // 2, g])
    cv2.imwrite(str(tmp_path / "c.png"), c)
    with pytest.raises(ValueError, match="colour"):
        read_image(tmp_path / "c.png")
    lum = read_image(tmp_path / "c.png", color="luminance")
    np.testing.assert_allclose(lum.image, cv2.cvtColor(c, cv2.COLOR_BGR2GRAY) / 255.0, atol=1e-7)


def test_bad_files(tmp_path):
    (tmp_path / "x.png").write_bytes(b"not a png")
    with pytest.raises(ValueError, match="could not decode"):
        read_image(tmp_path / "x.png")
    with pytest.raises(ValueError, match="not a file"):
        read_image(tmp_path / "missing.png")
    (tmp_path / "x.gif").write_bytes(b"GIF89a")
    with pytest.raises(ValueError, match="unsupported suffix"):
        read_image(tmp_path / "x.gif")


@pytest.mark.parametrize(
    ("arr", "msg"),
    [
        (np.zeros((0, 5)), "empty"),
        (np.zeros((4, 4, 3)), "2-D"),
        (np.full((4, 4), np.nan), "non-finite"),
        (np.array([["a", "b"]]), "dtype"),
        (np.zeros((3, 3), complex), "dtype"),
    ],
)
def test_as_grey_float_rejects_bad_arrays(arr, msg):
    with pytest.raises(ValueError, match=msg):
        as_grey_float(arr)

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


def _png_header_only(path, width, height):
    """A PNG whose IHDR declares width × height 8-bit grey but whose pixel data is cut
    short: the size is in the header, decoding would need width·height bytes."""
    import struct
    import zlib

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(
            ">I", zlib.crc32(kind + data) & 0xFFFFFFFF
        )

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    body = chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(bytes(1000))) + chunk(b"IEND", b"")
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + body)
    return path


def test_10000_by_10000_image_refused_before_decoding(tmp_path):
    """The size comes from the header: refused with the size and the bound named, and
    without decoding (the pixel data in the file is a few bytes)."""
    from slam.io.images import MAX_IMAGE_PIXELS

    big = _png_header_only(tmp_path / "big.png", 10_000, 10_000)
    assert big.stat().st_size < 2000
    with pytest.raises(ValueError, match=rf"10000 x 10000 = 100000000 px exceeds the bound of {MAX_IMAGE_PIXELS}"):
        read_image(big)


def test_max_pixels_bound_is_exact(tmp_path, rng):
    img = rng.integers(0, 255, size=(30, 40)).astype(np.uint8)
    path = tmp_path / "s.png"
    cv2.imwrite(str(path), img)
    assert read_image(path, max_pixels=1200).image.shape == (30, 40)
    with pytest.raises(ValueError, match="40 x 30 = 1200 px exceeds the bound of 1199"):
        read_image(path, max_pixels=1199)

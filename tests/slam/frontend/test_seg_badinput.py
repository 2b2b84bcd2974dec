"""Bad and degenerate input: clear ValueErrors or documented results, never a crash or a
division by zero (RuntimeWarnings from slam.* are errors under pytest.ini)."""

from __future__ import annotations

import numpy as np
import pytest

from slam.frontend.segmentation import (
    METHODS,
    SegmentationParams,
    as_gray8,
    get_preset,
    improved_otsu,
    load_gray8,
    params_for_shape,
    score_detections,
    segment,
)


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("value", [0, 1, 128, 255])
def test_constant_image_has_no_regions(method, value):
    """Documented result: a constant image has no regions; thresholds = its level."""
    img = np.full((50, 70), value, np.uint8)
    res = segment(img, method, "low-res-sss")
    assert res.regions == () and res.landmarks == ()
    assert not res.mask.any() and not res.binary.any()
    assert not res.retriggered


@pytest.mark.parametrize("method", METHODS)
def test_constant_float_image_has_no_regions(method):
    res = segment(np.full((30, 30), 3.7), method, "low-res-sss")
    assert res.regions == ()


@pytest.mark.parametrize(
    ("image", "match"),
    [
        (np.zeros((0, 10), np.uint8), "empty"),
        (np.zeros((0,), np.uint8), "not 2-D"),
        (np.full((10, 10), np.nan), "NaN"),
        (np.array([[1.0, np.inf], [0.0, 1.0]]), "NaN or infinite"),
        (np.zeros((10, 10, 3), np.uint8), "not 2-D"),
        (np.zeros((10, 10), bool), "dtype bool"),
        (np.zeros((10, 10), complex), "dtype complex"),
        (np.array([["a", "b"]]), "dtype"),
    ],
)
@pytest.mark.parametrize("method", ["improved-otsu", "kapur"])
def test_bad_images_raise_value_error(image, match, method):
    with pytest.raises(ValueError, match=match):
        segment(image, method, "low-res-sss")


def test_other_dtypes_are_stretched_to_8_bit():
    """uint16 / float / signed images are stretched from [min, max] to [0, 255]."""
    img16 = np.array([[1000, 2000], [3000, 1000]], np.uint16)
    assert as_gray8(img16).tolist() == [[0, 128], [255, 0]]
    imgf = np.array([[-1.0, 0.0], [1.0, 1.0]])
    assert as_gray8(imgf).tolist() == [[0, 128], [255, 255]]
    assert as_gray8(np.array([[-5, 5]], np.int32)).tolist() == [[0, 255]]


def test_16_bit_image_segments_like_its_8_bit_version(rng):
    """A uint16 image whose values are 257 × an 8-bit image gives the same segmentation."""
    img8 = np.clip(rng.normal(50, 15, (80, 80)), 0, 255).astype(np.uint8)
    img8[0, 0], img8[1, 1] = 0, 255
    img8[30:50, 30:50] = 240
    r8 = improved_otsu(img8, "low-res-sss")
    r16 = improved_otsu(img8.astype(np.uint16) * 257, "low-res-sss")
    assert r8.threshold_star == r16.threshold_star
    assert np.array_equal(r8.mask, r16.mask)


def test_unknown_method_and_preset():
    img = np.zeros((10, 10), np.uint8)
    with pytest.raises(ValueError, match="method='sobel'"):
        segment(img, "sobel")
    with pytest.raises(ValueError, match="preset='huge'"):
        segment(img, "otsu", "huge")
    with pytest.raises(ValueError, match="params"):
        segment(img, "otsu", 42)
    with pytest.raises(ValueError, match="needs the image shape"):
        get_preset("auto")


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("a_px", 0),
        ("n_max", -1),
        ("canny_high", 0.0),
        ("canny_high", 1.5),
        ("gaussian_ksize", 4),
        ("dilate_iterations", -1),
        ("power_r", 0.0),
    ],
)
def test_bad_params_name_the_field(field, value):
    with pytest.raises(ValueError, match=field):
        SegmentationParams(**{field: value})


def test_size_rule_reproduces_thesis_presets():
    """The documented rule gives a within 1 px of the thesis's 30 / 15 / 40 and the
    area/(a·N_max) ratio ≈ 70 (thesis: 63.4–74.6)."""
    for shape, a_ref in [((800, 800), 30), ((228, 417), 15), ((932, 1920), 40)]:
        p = params_for_shape(shape)
        assert abs(p.a_px - a_ref) <= 1
        ratio = shape[0] * shape[1] / (p.a_px * p.n_max)
        assert 63.0 <= ratio <= 75.0
    assert get_preset("sdvd").a_px == 14 and get_preset("sdvd").n_max == 67
    with pytest.raises(ValueError, match="shape"):
        params_for_shape((0, 5))


def test_tiny_images_do_not_crash():
    for shape in [(1, 1), (1, 7), (2, 2), (3, 1)]:
        img = np.arange(np.prod(shape), dtype=np.uint8).reshape(shape) * 40
        for m in METHODS:
            segment(img, m, "low-res-sss")


def test_load_errors(tmp_path):
    with pytest.raises(ValueError, match=r"does not exist|not a file"):
        load_gray8(tmp_path / "missing.png")
    bad = tmp_path / "bad.png"
    bad.write_bytes(b"not a png")
    with pytest.raises(ValueError, match="decode"):
        load_gray8(bad)


def test_mask_shape_mismatch():
    with pytest.raises(ValueError, match="not 2-D"):
        score_detections([[1, 1]], np.zeros((4, 4, 3)))


def test_load_16_bit_and_grey_as_colour_files(tmp_path):
    """A 16-bit PNG of 257 × an 8-bit image loads as that 8-bit image (full-range
    stretch); a grey image saved as 3 equal channels loads as the grey image."""
    import cv2

    img8 = np.tile(np.arange(256, dtype=np.uint8), (4, 1))
    cv2.imwrite(str(tmp_path / "a16.png"), img8.astype(np.uint16) * 257)
    assert np.array_equal(load_gray8(tmp_path / "a16.png"), img8)
    cv2.imwrite(str(tmp_path / "rgb.png"), np.dstack([img8, img8, img8]))
    assert np.array_equal(load_gray8(tmp_path / "rgb.png"), img8)

"""Side-scan window conditioning when the swath runs past the end of the seabed.

A ping whose far samples carry no echo (the seabed ends: the edge of the surveyed area)
ends in a run of display-floor samples. Expectations, independent of the code:

* the trailing floor run of each side, and only it, is "no return" (constructed mask);
* a speckled seabed without any object, with a dead far-range block on one side, gives
  no detection (there is nothing to detect: every region would be a false positive) and
  its prepared image is ~0 dB everywhere the seabed or the dead block is.
"""

from __future__ import annotations

import numpy as np
import pytest

from slam.frontend.sidescan_prepare import make_sss_prepare, no_return_mask
from slam.frontend.sidescan_records import PingRecord
from slam.frontend.sidescan_windows import SidescanProcessor

DR_DB = 50.0  # display dynamic range of the synthetic sonar, dB
FLOOR_DB = -20.0  # 10 log10 intensity mapped to display 0


def _log_compress(lin: np.ndarray) -> np.ndarray:
    return np.clip((10.0 * np.log10(np.maximum(lin, 1e-30)) - FLOOR_DB) / DR_DB, 0.0, 1.0)


def _waterfall(rng, *, pings=200, s=500, alt=10.0, dead_from_m=32.0, looks=4):
    """Log-compressed (pings, 2s) waterfall of a flat, object-free seabed: a TVG-flattened
    mean intensity (slow exponential decay with the sample index), ``looks``-look speckle
    (gamma intensity, mean 1), a dim water column (slant < alt), a bright first bottom
    return (1 m of slant range from the altitude) and, on starboard, no echo at all from
    slant range ``dead_from_m`` outward (display floor 0)."""
    slant = (np.arange(s) + 0.5) * 0.1  # 0.1 m bins out to 50 m
    mean = 10.0 * np.exp(-np.arange(s) / 2000.0)
    mean = np.where(slant < alt, 0.02, mean)
    mean[(slant >= alt) & (slant < alt + 1.0)] *= 30.0
    lin = np.broadcast_to(np.concatenate([mean[::-1], mean]), (pings, 2 * s)).copy()
    lin *= rng.gamma(looks, 1.0 / looks, lin.shape)
    x = _log_compress(lin)
    x[:, s:][:, slant >= dead_from_m] = 0.0
    return x.astype(np.float32), slant, alt


def test_no_return_mask_flags_only_the_trailing_floor_run():
    """Constructed pings: a dark sample inside the swath (a shadow) is kept; the floor run
    at the far end of each side is flagged; a side with echo to its last sample has none."""
    s = 6
    img = np.ones((2, 2 * s), np.float32)
    img[0, :2] = 0.0  # port far end (leftmost) dead for 2 samples
    img[0, s + 2] = 0.0  # starboard shadow sample before the last echo
    img[1, s + 3 :] = 0.0  # starboard dead from sample 3
    m = no_return_mask(img)
    want = np.zeros_like(m)
    want[0, :2] = True
    want[1, s + 3 :] = True
    np.testing.assert_array_equal(m, want)


def test_no_return_mask_rejects_odd_width():
    with pytest.raises(ValueError, match="img must be"):
        no_return_mask(np.ones((3, 5)))


def _segment(img):
    from slam.frontend.segmentation.methods import segment

    res = segment(img, method="improved-otsu", params="auto")
    return res.labels, list(res.regions)


@pytest.mark.parametrize("seed", [0, 1])
def test_object_free_seabed_with_dead_far_range_gives_no_detection(seed):
    """No object anywhere, starboard cut off at 32 m slant (of 50 m): no detection, no
    seabed pixel beyond the nadir band segmented, and the prepared seabed and dead block
    at ~0 dB (seabed level 1). Before the dead block was handled it stayed at -10 dB, the
    window's histogram was bimodal, Otsu's threshold fell between the dead block and the
    seabed and ~3/4 of the seabed came out as foreground (checked against the previous
    commit: T = 35-37 of 255, 77 % of the seabed beyond 5 m)."""
    rng = np.random.default_rng(seed)
    img, slant, alt = _waterfall(rng)
    s = slant.size
    prep = make_sss_prepare(True, DR_DB)(img, np.full(img.shape[0], alt), slant)
    seabed = slant >= alt + 1.0
    for side in (prep[:, :s][:, ::-1], prep[:, s:]):
        assert abs(float(side[:, seabed].mean())) < 1.0  # dB
    assert abs(float(prep[:, s:][:, slant >= 33.0].mean())) < 1e-6  # dead block at 0 dB
    ground = np.sqrt(np.clip(slant**2 - alt**2, 0.0, None))
    beyond_nadir = np.concatenate([ground[::-1], ground]) > alt / 2 + 1.0
    lab, _ = _segment(prep)
    assert np.count_nonzero(lab[:, beyond_nadir]) == 0
    proc = SidescanProcessor(_segment, 200, 100, prepare=make_sss_prepare(True, DR_DB))
    dets = []
    for k in range(img.shape[0]):
        lab = np.zeros(2 * s, np.int32)
        pose = np.array([0.1 * k, 0.0, 0.0])
        res = proc.add(PingRecord(k / 10.0, img[k], slant, alt, 1.0, labels=lab, pose_true=pose))
        if res is not None:
            dets += res.detections
    assert dets == []

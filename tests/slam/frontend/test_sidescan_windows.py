"""Side-scan windowing: every ping owned once, an object seen in two overlapping windows
gives one detection, with the range and ping of the object."""

from __future__ import annotations

import numpy as np

from slam.frontend.sidescan_records import PingRecord
from slam.frontend.sidescan_windows import SidescanProcessor


def _threshold_segment(img):
    """A plain threshold + scipy labelling as the stand-in front end for this test (the
    real front end is tested in tests/slam); regions carry label/area/centroid/bbox."""
    from scipy import ndimage

    lab, _n = ndimage.label(img > 5.0)
    regs = []
    for i, sl in enumerate(ndimage.find_objects(lab), start=1):
        rr, cc = np.nonzero(lab[sl] == i)

        class R:
            pass

        r = R()
        r.label, r.area_px = i, rr.size
        r.centroid_rc = (rr.mean() + sl[0].start, cc.mean() + sl[1].start)
        r.bbox = (sl[0].start, sl[1].start, sl[0].stop, sl[1].stop)
        regs.append(r)
    return lab, regs


def _pings(n, S, obj_pings, obj_sample, h=8.0, dt=0.1, speed=1.5):
    ranges = (np.arange(S) + 0.5) * 0.2  # bin centres, as SSSPing.slant_range
    out = []
    for k in range(n):
        inten = np.ones(2 * S, np.float32)
        labels = np.zeros(2 * S, np.int32)
        if k in obj_pings:  # object on starboard at sample obj_sample (3 samples wide)
            inten[S + obj_sample - 1 : S + obj_sample + 2] = 10.0
            labels[S + obj_sample - 1 : S + obj_sample + 2] = 7
        out.append(
            PingRecord(
                k * dt,
                inten,
                ranges,
                h,
                speed,
                labels=labels,
                pose_true=np.array([k * dt * speed, 0.0, 0.0]),
            )
        )
    return out, ranges


def test_object_in_overlap_detected_once_at_its_ping_and_range():
    """The object sits in pings 60-64, inside the overlap of windows [0, 80) and [40, 120):
    exactly one detection, tied to ping 62 (t = 6.2 s), ground range sqrt(r² - h²),
    starboard bearing -90°."""
    S = 200
    pings, ranges = _pings(200, S, set(range(60, 65)), 100)
    proc = SidescanProcessor(_threshold_segment, window=80, hop=40, min_area_px=3)
    dets = []
    for p in pings:
        res = proc.add(p)
        if res:
            dets += res.detections
    res = proc.flush()
    if res:
        dets += res.detections
    assert len(dets) == 1
    d = dets[0]
    assert d.ping == 62 and np.isclose(d.t, 6.2)
    assert np.isclose(d.ground_range, np.sqrt(ranges[100] ** 2 - 64.0), atol=1e-6)
    assert np.isclose(d.observation.z[1], -np.pi / 2) and d.side == "starboard"
    assert d.object_id == 7 and d.true_positive
    assert np.allclose(d.world_xy_true_pose, [62 * 0.15, -d.ground_range])


def test_every_ping_owned_exactly_once():
    """Objects every 30 pings (4.5 m apart, beyond the merge radius): each one is detected
    exactly once over all windows, and the released horizon only moves forward."""
    S = 100
    obj = set(range(5, 300, 30))
    pings, _ = _pings(300, S, obj, 50)
    proc = SidescanProcessor(_threshold_segment, window=64, hop=16, min_area_px=3)
    seen = []
    horizons = []
    for p in pings:
        r = proc.add(p)
        if r:
            seen += [d.ping for d in r.detections]
            horizons.append(r.horizon_t)
    r = proc.flush()
    seen += [d.ping for d in r.detections]
    assert sorted(seen) == sorted(obj)
    assert all(np.diff(horizons) > 0)

"""Side-scan waterfall windows -> detections -> SLAM observations.

Pings accumulate in a waterfall ``(pings, 2 x samples)`` (port left, starboard right).
Every ``hop`` pings, the last ``window`` pings are segmented by the front end
(slam.frontend.segmentation). Windows overlap, so the same object appears in two of
them; each ping is *owned* by exactly one window - the one in which it lies in the
central ``hop`` rows ([a + (W - H) / 2, a + (W + H) / 2) for the window starting at
ping a) - and only regions whose centroid falls in owned rows become detections. That
gives every region context on both sides and never reports one object twice from two
windows. Several regions of one object (a wreck broken into highlights) within one
window are merged when their ground positions (relative to the vehicle track) lie
closer than ``merge_radius`` (single linkage on the gap between their footprints in
metres: along-track x ground range). Regions in the nadir band (ground range below
max(min_ground_range, altitude / 2): the first bottom return) and regions smaller than
``min_area_m2`` on the ground (pixel = bin width x along-track spacing; speckle blobs)
are ignored.

Each detection is tied to the ping k nearest its centroid (time t_k): the observation
comes from the front end's side-scan observation model
(slam.frontend.observation.range_bearing_from_pixels with a SideScanGeometry built from
ping k: its bottom-tracked altitude, the along-track spacing speed / ping rate), i.e.
ground range sqrt(r^2 - h^2) and bearing ~ +90 deg (port) / -90 deg (starboard) seen
from the pose at ping k, with a covariance from cell sizes and the region's extent.
Detections whose centroid lies in the water column (slant range < altitude) give no
observation. A view-dependent term is added to that covariance: a side-scan highlight
is the sonar-facing part of an object, so its centroid moves across the object between
passes from opposite sides; ``view_bias`` x the region's across-track extent (range) and
along-track extent (as a bearing) are added as standard deviations (0.5: half the
extent), so re-observations from the other side still pass the association gates. slam.pipeline feeds it to SLAM at the pose of t_k
(slam.pipeline.lagged).

Scoring uses the simulator's per-sample labels: a detection is a true positive when at
least ``tp_fraction`` of its region's pixels carry an object id > 0.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from slam.frontend.observation import SideScanGeometry, range_bearing_from_pixels
from slam.types import RangeBearing


@dataclass(frozen=True)
class PingRecord:
    """One side-scan ping as the windowing keeps it.

    t: acquisition time, s. intensity (2S,) float32, port left (far range first).
    slant_range (S,) m of the starboard half's samples (near to far; port mirrored).
    altitude: measured altitude (DVL or first return), m. speed: along-track speed
    estimate, m/s (for the along-track pixel size).
    Ground truth, optional (scoring only; a recording has none): labels (2S,) int32
    object id per sample (0 seabed, -1 no return, k >= 1 object k); pose_true (3,)
    [x, y, yaw]. Without them detections carry object id 0, are not true positives and
    are placed with ``pose_nav`` (the navigation pose, when given).
    """

    t: float
    intensity: np.ndarray
    slant_range: np.ndarray
    altitude: float
    speed: float = 1.5
    labels: np.ndarray | None = None
    pose_true: np.ndarray | None = None
    pose_nav: np.ndarray | None = None


@dataclass(frozen=True)
class Detection:
    """One side-scan detection tied to the ping of its centroid."""

    t: float
    ping: int
    side: str  # "port" | "starboard"
    slant_range: float
    ground_range: float
    area_px: int
    observation: RangeBearing
    object_id: int  # majority simulator label of the region (0 = none) - scoring only
    true_positive: bool
    world_xy_true_pose: np.ndarray  # placed with the true pose (else the nav pose, else NaN)


@dataclass
class WindowResult:
    """One segmented window: its image, class-id overlay and detections owned here."""

    start: int
    image: np.ndarray
    overlay: np.ndarray
    detections: list[Detection]
    horizon_t: float  # every ping at or before this time is final (no later detections)
    fp_pixels: int = 0
    bg_pixels: int = 0
    imaged_ids: set = field(default_factory=set)


class SidescanProcessor:
    """Windows a side-scan waterfall and turns segmented regions into detections.

    segment(image float32 (W, 2S)) -> (labels int (W, 2S) regions 1..n, regions list with
    .label .area_px .centroid_rc .bbox) - a thin adapter over the front end.
    """

    def __init__(
        self,
        segment: Callable[[np.ndarray], tuple[np.ndarray, list]],
        window: int,
        hop: int,
        *,
        min_area_px: int = 4,
        merge_radius: float = 3.0,
        tp_fraction: float = 0.1,
        class_of: Callable[[int], int] | None = None,
        along_track_beamwidth_deg: float = 0.0,
        altitude_sigma: float = 0.1,
        prepare: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray] | None = None,
        min_ground_range: float = 2.0,
        view_bias: float = 0.5,
        min_area_m2: float = 0.0,
        edge_mask: Callable[[np.ndarray], np.ndarray] | None = None,
    ) -> None:
        if not 1 <= hop <= window:
            raise ValueError(f"hop must be in [1, window={window}], got {hop}")
        self.segment = segment
        self.window = int(window)
        self.hop = int(hop)
        self.min_area_px = int(min_area_px)
        self.merge_radius = float(merge_radius)
        self.tp_fraction = float(tp_fraction)
        self.class_of = class_of or (lambda oid: 1 if oid > 0 else 0)
        self.along_track_beamwidth_deg = float(along_track_beamwidth_deg)
        self.altitude_sigma = float(altitude_sigma)
        self.horizon = -np.inf  # pings at or before this time are final
        self.prepare = prepare
        self.min_ground_range = float(min_ground_range)
        self.view_bias = float(view_bias)
        self.min_area_m2 = float(min_area_m2)
        # raw window (W, 2S) -> bool mask of the water column and first-return edge;
        # a detection centred there is the edge, not an object (recorded data)
        self.edge_mask = edge_mask
        self.pings: list[PingRecord] = []
        self._next_start = 0  # start ping of the next window
        self._owned_until = 0  # pings < this are owned by processed windows

    def add(self, ping: PingRecord) -> WindowResult | None:
        """Add one ping; returns a WindowResult when a window was processed."""
        self.pings.append(ping)
        if len(self.pings) >= self._next_start + self.window:
            return self._process(self._next_start, final=False)
        return None

    def flush(self) -> WindowResult | None:
        """Process the remaining pings (end of run)."""
        n = len(self.pings)
        if n <= self._owned_until:
            return None
        start = max(0, n - self.window)
        return self._process(start, final=True)

    def _process(self, a: int, final: bool) -> WindowResult:
        W, H = self.window, self.hop
        pings = self.pings[a : a + W]
        img = np.stack([p.intensity for p in pings]).astype(np.float32)
        edge = self.edge_mask(img) if self.edge_mask is not None else None
        lab = np.stack(
            [p.labels if p.labels is not None else np.zeros(img.shape[1], np.int32) for p in pings]
        ).astype(np.int32)
        if self.prepare is not None:
            img = self.prepare(img, np.array([p.altitude for p in pings]), pings[0].slant_range)
        own_lo = self._owned_until
        own_hi = len(self.pings) if final else a + (W + H) // 2
        seg_labels, regions = self.segment(img)
        fg = seg_labels > 0
        rows_owned = slice(max(own_lo - a, 0), max(own_hi - a, 0))
        bg = lab[rows_owned] == 0
        fp_pixels = int(np.count_nonzero(fg[rows_owned] & bg))
        bg_pixels = int(np.count_nonzero(bg))
        imaged = set(np.unique(lab[rows_owned][lab[rows_owned] > 0]).tolist())
        overlay = np.zeros(img.shape, np.uint16)
        dets = self._detections(
            a, pings, img, lab, seg_labels, regions, own_lo, own_hi, overlay, edge
        )
        self._owned_until = own_hi
        self._next_start = a + H
        horizon = self.pings[own_hi - 1].t
        self.horizon = horizon
        return WindowResult(a, img, overlay, dets, horizon, fp_pixels, bg_pixels, imaged)

    def _detections(
        self, a, pings, img, lab, seg_labels, regions, own_lo, own_hi, overlay, edge=None
    ) -> list[Detection]:
        S = img.shape[1] // 2
        rate = self._ping_rate()
        cand = self._candidates(a, S, lab, seg_labels, regions, own_lo, own_hi, overlay, rate)
        # merge regions of one object (single linkage): same side, gap between their
        # footprints (along-track x ground range, metres) below merge_radius
        groups = self._merge(cand, rate)
        out = []
        for grp in groups:
            w = np.array([g_[4] for g_ in grp], float)
            row = float(np.average([g_[0] for g_ in grp], weights=w))
            col = float(np.average([g_[1] for g_ in grp], weights=w))
            k = round(row)
            if edge is not None and edge[k - a, min(round(col), img.shape[1] - 1)]:
                continue  # centred on the first-return edge / water column
            port = grp[0][2]
            bb = np.array([g_[5] for g_ in grp])
            ext = (float(bb[:, 2].max() - bb[:, 0].min()), float(bb[:, 3].max() - bb[:, 1].min()))
            big = max(grp, key=lambda x: x[4])
            oid, frac = big[6], float(np.average([g_[7] for g_ in grp], weights=w))
            p = self.pings[k]
            bin_w = float(np.median(np.diff(p.slant_range))) if len(p.slant_range) > 1 else 0.05
            geom = SideScanGeometry(
                slant_range_max=float(p.slant_range[-1] + bin_w / 2),
                samples_per_side=S,
                altitude=max(float(p.altitude), 0.0),
                along_track_spacing=max(p.speed, 0.05) / rate,
                slant_range_min=max(float(p.slant_range[0] - bin_w / 2), 0.0),
                along_track_beamwidth_deg=self.along_track_beamwidth_deg,
                altitude_sigma=self.altitude_sigma,
            )
            try:
                rng_, brg, cov = range_bearing_from_pixels(
                    geom, np.array([[row - a, col]]), np.array([ext]), ref_row=float(k - a)
                )
            except ValueError:  # centroid in the water column (no ground range): no observation
                continue
            R = cov[0].copy()
            if self.view_bias > 0:  # the highlight's place on the object depends on the view
                R[0, 0] += (self.view_bias * ext[1] * bin_w) ** 2
                R[1, 1] += (
                    self.view_bias * ext[0] * geom.along_track_spacing / max(rng_[0], 1.0)
                ) ** 2
            obs = RangeBearing([rng_[0], brg[0]], R, t=p.t, meta={"object_id": oid, "ping": k})
            x, y, yaw = _placing_pose(p)
            wxy = np.array([x + rng_[0] * np.cos(yaw + brg[0]), y + rng_[0] * np.sin(yaw + brg[0])])
            slant = float(np.hypot(rng_[0], p.altitude))
            out.append(
                Detection(
                    p.t,
                    k,
                    "port" if port else "starboard",
                    slant,
                    float(rng_[0]),
                    int(w.sum()),
                    obs,
                    oid,
                    frac >= self.tp_fraction,
                    wxy,
                )
            )
        out.sort(key=lambda d: (d.t, d.side, d.ground_range))
        return out

    def _candidates(self, a, S, lab, seg_labels, regions, own_lo, own_hi, overlay, rate):
        """Regions of the owned rows that may be detections: size, ground-area and nadir
        tests; per region [row, col, port, ground range, area, bbox, object id, object
        fraction, (near, far) ground range]. Marks each in the overlay."""
        flat_seg = seg_labels.ravel()
        order = np.argsort(flat_seg, kind="stable")
        bounds = np.searchsorted(flat_seg[order], np.arange(int(flat_seg.max(initial=0)) + 2))
        cand = []
        for reg in regions:
            if reg.area_px < self.min_area_px:
                continue
            if self.min_area_m2 > 0:  # speckle blobs are small on the ground
                pk = self.pings[min(a + round(reg.centroid_rc[0]), len(self.pings) - 1)]
                px_m2 = float(np.median(np.diff(pk.slant_range))) * max(pk.speed, 0.05) / rate
                if reg.area_px * px_m2 < self.min_area_m2:
                    continue
            r, c = reg.centroid_rc
            k = a + round(r)
            if not own_lo <= k < own_hi:
                continue
            idx = order[bounds[reg.label] : bounds[reg.label + 1]]
            region_labels = lab.ravel()[idx]
            objs = region_labels[region_labels > 0]
            oid = int(np.bincount(objs).argmax()) if objs.size else 0
            frac = objs.size / max(idx.size, 1)
            overlay.ravel()[idx] = self.class_of(oid) if oid > 0 else 255
            port = c < S - 0.5
            sample = int(np.clip(round((S - 1 - c) if port else (c - S)), 0, S - 1))
            p = self.pings[k]
            rs = float(p.slant_range[sample])
            g = float(np.sqrt(max(rs * rs - p.altitude**2, 0.0)))
            if g < max(self.min_ground_range, 0.5 * p.altitude):  # nadir band: first return
                continue
            r0, c0, r1, c1 = reg.bbox
            s0 = (S - c1) if port else (c0 - S)  # nearest sample of the box from nadir
            s1 = (S - 1 - c0) if port else (c1 - 1 - S)
            sl = p.slant_range[np.clip([s0, s1], 0, S - 1)]
            gi = np.sqrt(np.clip(sl**2 - p.altitude**2, 0.0, None))
            cand.append(
                [
                    a + r,
                    c,
                    port,
                    g,
                    reg.area_px,
                    (a + r0, c0, a + r1, c1),
                    oid,
                    frac,
                    (gi[0], gi[1]),
                ]
            )
        return cand

    def _merge(self, cand: list, rate: float) -> list[list]:
        n = len(cand)
        parent = list(range(n))

        def find(i):
            while parent[i] != i:
                parent[i] = parent[parent[i]]
                i = parent[i]
            return i

        for i in range(n):
            for j in range(i + 1, n):
                a_, b_ = cand[i], cand[j]
                if a_[2] != b_[2]:
                    continue
                spacing = max(self.pings[round(a_[0])].speed, 0.1) / rate
                gap_al = max(0.0, max(a_[5][0], b_[5][0]) - min(a_[5][2], b_[5][2])) * spacing
                gap_g = max(0.0, max(a_[8][0], b_[8][0]) - min(a_[8][1], b_[8][1]))
                if np.hypot(gap_al, gap_g) < self.merge_radius:
                    parent[find(i)] = find(j)
        groups: dict[int, list] = {}
        for i in range(n):
            groups.setdefault(find(i), []).append(cand[i])
        return [groups[k] for k in sorted(groups)]

    def _ping_rate(self) -> float:
        n = len(self.pings)
        if n < 2:
            return 10.0
        dt = (self.pings[-1].t - self.pings[0].t) / (n - 1)
        return 1.0 / dt if dt > 0 else 10.0


def _placing_pose(p: PingRecord) -> np.ndarray:
    """The pose a detection is placed with: true (scoring), else navigation, else NaN."""
    if p.pose_true is not None:
        return np.asarray(p.pose_true, float)
    if p.pose_nav is not None:
        return np.asarray(p.pose_nav, float)
    return np.full(3, np.nan)


def no_return_mask(img: np.ndarray) -> np.ndarray:
    """(P, 2S) bool: samples past the last echo of each ping side (port left, far first).

    A side-scan ping that runs past the end of the insonified seabed (the swath cut off by
    the edge of the surveyed area, a bank, the end of the recorded range) ends in a run of
    samples at the display floor (value <= 0, log-compressed or linear). That trailing run,
    counted from the far end of each side, is flagged; isolated dark samples before the
    last echo (speckle dips, shadows behind objects) are not. Vectorized over pings.
    """
    x = np.asarray(img)
    if x.ndim != 2 or x.shape[1] % 2:
        raise ValueError(f"img must be (pings, 2 x samples), got shape {x.shape}")
    s = x.shape[1] // 2
    echo = x > 0
    # per side, near -> far; the last echo index (-1: none)
    out = np.empty(x.shape, dtype=bool)
    for cols, flip in ((slice(None, s), True), (slice(s, None), False)):
        e = echo[:, cols][:, ::-1] if flip else echo[:, cols]
        last = np.where(e.any(axis=1), s - 1 - np.argmax(e[:, ::-1], axis=1), -1)
        m = np.arange(s)[None, :] > last[:, None]
        out[:, cols] = m[:, ::-1] if flip else m
    return out


#: dB span of a prepared side-scan window (re the normalized seabed level): fixed, so a
#: display of the windows can use one mapping for a whole run
PREPARED_DB = (-10.0, 20.0)


def make_sss_prepare(
    log_compressed: bool, dynamic_range_db: float, looks: int = 3, normalization: str = "mira"
):
    """The front end's input conditioning for a side-scan window, in order:

    1. back to linear intensity if the sonar log-compressed its output for display
       (x in [0, 1] spans ``dynamic_range_db``; the offset cancels in step 2);
    2. normalization -> ~1 on average seabed, by ``normalization``:
       ``"mira"`` (slam.frontend.normalization.mira_normalize, thesis Ch. 4.1: per side,
       mixed-exponential fit of the range profile, 9 pings averaged around the window's
       middle ping), or ``"column-median"``: each range sample divided by its median over
       the window's pings (the usual empirical along-track normalization; it also removes
       range-gain shapes the two exponentials cannot fit, such as a rise near nadir);
    3. the water column (slant range < altitude of that ping) and the samples past the
       last echo of a ping (:func:`no_return_mask`: a swath cut off by the end of the
       seabed) set to the seabed level 1, so the threshold separates highlights from
       seabed, not seabed from water or from no data (a large no-data block at -10 dB
       makes the window's histogram bimodal and drags the threshold into the seabed);
    4. ``looks`` x ``looks`` incoherent averaging (cv2.blur) against single-look speckle;
    5. dB (10 log10, clipped to [-10, 20] dB) for the segmentation.
    """
    import cv2

    from slam.frontend.normalization import mira_normalize

    if normalization not in ("mira", "column-median"):
        raise ValueError(f"normalization: got {normalization!r}; allowed: mira, column-median")

    def prepare(img: np.ndarray, altitudes: np.ndarray, slant: np.ndarray) -> np.ndarray:
        lin = (
            np.power(10.0, img * (dynamic_range_db / 10.0))
            if log_compressed
            else img.astype(np.float64)
        )
        noret = no_return_mask(img)
        if normalization == "mira":
            m = mira_normalize(lin.astype(np.float32), average=9).normalized
        else:
            m = lin / np.maximum(np.median(lin, axis=0, keepdims=True), 1e-12)
        S = m.shape[1] // 2
        wc = slant[None, :] < altitudes[:, None]  # (P, S) near -> far
        full = np.concatenate([wc[:, ::-1], wc], axis=1) | noret
        m = np.where(full, 1.0, m).astype(np.float32)
        if looks > 1:
            m = cv2.blur(m, (looks, looks))
        assert m.shape[1] == 2 * S
        lo, hi = (10.0 ** (v / 10.0) for v in PREPARED_DB)
        return (10.0 * np.log10(np.clip(m, lo, hi))).astype(np.float32)

    return prepare


def make_fls_prepare(
    log_compressed: bool,
    dynamic_range_db: float,
    looks: int = 5,
    window: int = 15,
    floor: float = 0.02,
):
    """Conditioning of an FLS polar frame (bins, beams) before segmentation: linear
    intensity; each cell divided by the median of its ``window`` x ``window`` neighbourhood
    (a local background estimate: the seabed's level changes with range and grazing angle
    across the fan, so a per-range normalization is not enough; scipy.ndimage); cells
    without a return (display value <= ``floor``) set to the background level 1;
    ``looks`` x ``looks`` averaging against speckle; dB for the segmentation."""
    import cv2
    from scipy import ndimage

    def prepare(img: np.ndarray) -> np.ndarray:
        x = img.astype(np.float64)
        lin = np.power(10.0, x * (dynamic_range_db / 10.0)) if log_compressed else x
        valid = x > (floor if log_compressed else floor * max(float(x.max()), 1e-30))
        if not valid.any():
            return np.zeros(x.shape, np.float32)
        fill = float(np.median(lin[valid]))
        bg = ndimage.median_filter(np.where(valid, lin, fill), size=window)
        m = np.where(valid, lin / np.maximum(bg, 1e-30), 1.0).astype(np.float32)
        if looks > 1:
            m = cv2.blur(m, (looks, looks))
        lo, hi = (10.0 ** (v / 10.0) for v in PREPARED_DB)
        return (10.0 * np.log10(np.clip(m, lo, hi))).astype(np.float32)

    return prepare

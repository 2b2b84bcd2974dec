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
or longer than ``max_extent_m`` along track or across (a seabed band or patch: its
centroid is no repeatable point for a point landmark) are ignored.

An object cut by a window's trailing edge (a wreck longer than the hop) is held and
merged with its continuation in the next window, so it becomes one detection of the
whole object (the released horizon waits for it: slam.frontend.extended_objects.Part).

Each detection is tied to the ping k nearest its centre (time t_k) and located by
slam.frontend.sidescan_detection (highlight + shadow, else the highlight's centroid).
slam.pipeline feeds each to SLAM at the pose of t_k (slam.pipeline.lagged).

Scoring uses the simulator's per-sample labels: a detection is a true positive when at
least ``tp_fraction`` of its region's pixels carry an object id > 0.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from slam.frontend.extended_objects import (
    SHADOW,
    Part,
    ShadowConfig,
    merge_parts,
    row_profile,
)
from slam.frontend.sidescan_detection import object_detection
from slam.frontend.sidescan_records import Detection, PingRecord, WindowResult


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
        max_extent_m: float = np.inf,
        edge_mask: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
        drop_mirrored: bool = False,
        shadow: Callable[[np.ndarray], np.ndarray] | None = None,
        shadow_config: ShadowConfig = SHADOW,
        max_object_pings: int | None = None,
        require_shadow: bool = False,
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
        self.max_extent_m = float(max_extent_m)
        # (altitudes (W,) m, slant (S,) m) -> (W, 2S) bool mask of the water column and
        # first-return edge; a detection centred there is the edge, not an object, and
        # so are detections mirrored across nadir (drop_mirrored; recorded data)
        self.edge_mask = edge_mask
        self.drop_mirrored = bool(drop_mirrored)
        # raw window -> dB below the seabed level (extended_objects.make_shadow_db): the
        # objects' shadows give their centres; None: highlights only
        self.shadow = shadow
        self.shadow_config = shadow_config
        # recorded data: an object standing proud of the seabed casts a shadow; a
        # highlight without one (bright sediment, a lit rim of a larger object whose
        # shadow lies beyond shadow_config.max_gap_m) is no repeatable point landmark
        if require_shadow and shadow is None:
            raise ValueError("require_shadow needs the shadow callable (extended objects)")
        self.require_shadow = bool(require_shadow)
        # an object cut by the window's trailing edge is held for the next window until
        # it spans this many pings (default 3 windows)
        self.max_object_pings = int(max_object_pings or 3 * self.window)
        self._held: list[Part] = []
        # objects emitted by the last window, (port, pixels): the next window skips
        # the same object seen again across the ownership boundary
        self._claimed: list[tuple[bool, np.ndarray]] = []
        # ownership slack, pings: an object's centroid moves a little between two
        # windows' segmentations, so each window claims this far past its owned rows
        self._slack = max(2, self.hop // 20)
        self._long: list[tuple[bool, tuple[int, int, int, int]]] = []
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
        edge = (
            self.edge_mask(np.array([p.altitude for p in pings]), pings[0].slant_range)
            if self.edge_mask is not None
            else None
        )
        rel_db = self.shadow(img) if self.shadow is not None else None
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
        parts = self._candidates(
            a, img.shape[1] // 2, lab, seg_labels, regions, overlay, rel_db, edge
        )
        dets = self._detections(a, img, parts, own_lo, own_hi, final, edge)
        self._owned_until = own_hi
        self._next_start = a + H
        horizon = self.pings[own_hi - 1].t
        if self._held:  # a held object may still be observed at its first ping
            first = min(p.bbox[0] for p in self._held)
            horizon = min(horizon, self.pings[first].t - 1e-9)
        self.horizon = horizon
        return WindowResult(a, img, overlay, dets, horizon, fp_pixels, bg_pixels, imaged)

    def _detections(self, a, img, parts, own_lo, own_hi, final, edge=None) -> list[Detection]:
        """Merge the window's parts (and the objects held from the last window) into
        objects; hold those cut by the window's trailing edge; emit the rest whose
        centroid ping this window owns, and objects continuing a held one whose owner
        has passed (those a later window owns stay held)."""
        S = img.shape[1] // 2
        rate = self._ping_rate()
        held_ids = {id(p) for p in self._held}
        last = a + img.shape[0]
        # as before extended objects: only regions whose centroid this window owns, plus
        # those cut by its trailing edge (and the held ones) may merge - a region owned
        # by an earlier window must not chain its neighbours together
        m = self._slack
        parts = [
            p
            for p in parts
            if (
                own_lo - m <= (p.pix // (2 * S)).mean() + 0.5 < own_hi + m
                or (p.bbox[2] >= last and not final)
            )
            and not self._seen_before(p)  # the last window decided on it
        ]
        # a held object continued by a region too long to be an object is that band's
        # first part, not an object
        held = [h for h in self._held if not _overlaps_any(h, self._long)]
        groups = self._merge(held + parts, rate)
        self._held = []
        out, keep, claimed = [], [], []
        for grp in groups:
            obj = merge_parts(grp, S)
            span = obj.bbox[2] - obj.bbox[0]
            if not final and obj.bbox[2] >= last and span < self.max_object_pings:
                self._held.append(obj)
                continue
            continued = any(id(p) in held_ids for p in grp)
            row = float((obj.pix // (2 * S)).mean())
            k = round(row)
            if k >= own_hi + m and not final:  # a later window owns it: hold what was held
                if continued:
                    self._held.append(obj)
                continue
            if k < own_lo - m and not continued:  # an earlier window owned it
                continue
            claimed.append((obj.port, obj.pix))
            col = float((obj.pix % (2 * S)).mean())
            if edge is not None and a <= k < last:
                if edge[k - a, min(round(col), img.shape[1] - 1)]:
                    continue  # centred on the first-return edge / water column
            first = self.pings[min(obj.bbox[0], len(self.pings) - 1)]
            # parts may each pass the per-region test of _candidates: check the assembly
            if self._too_long(span, obj.ground, first.speed, rate):
                continue
            keep.append((obj, row, col))
        self._claimed = claimed
        mirrored = self._mirrored([(row, col) for _, row, col in keep], S)
        for (obj, row, col), twin in zip(keep, mirrored):
            if twin:  # its mirror across nadir: the first-return rim, not an object
                continue
            det = object_detection(
                obj,
                row,
                col,
                S,
                rate,
                self.pings,
                use_shadow=self.shadow is not None,
                require_shadow=self.require_shadow,
                altitude_sigma=self.altitude_sigma,
                along_track_beamwidth_deg=self.along_track_beamwidth_deg,
                view_bias=self.view_bias,
                tp_fraction=self.tp_fraction,
            )
            if det is not None:
                out.append(det)
        out.sort(key=lambda d: (d.t, d.side, d.ground_range))
        return out

    def _seen_before(self, part: Part) -> bool:
        """True when the last window decided on this region: one of the objects it
        claimed, on the same side, shares more than half of the smaller one's pixels."""
        return any(
            port == part.port
            and np.intersect1d(pix, part.pix, assume_unique=True).size
            > 0.5 * min(pix.size, part.pix.size)
            for port, pix in self._claimed
        )

    def _too_long(self, rows: int, ground: tuple[float, float], speed: float, rate: float) -> bool:
        """True when a footprint of ``rows`` pings (at ``speed`` m/s, ``rate`` Hz) by
        ``ground`` (near, far) m is longer than ``max_extent_m`` along track or across: a
        seabed band or patch, no repeatable point for a point landmark."""
        return max(rows * max(speed, 0.05) / rate, ground[1] - ground[0]) > self.max_extent_m

    def _mirrored(self, centres: list[tuple[float, float]], S: int) -> np.ndarray:
        """(n,) bool: groups mirrored across nadir (artefacts.mirrored_across_nadir)."""
        if not self.drop_mirrored or len(centres) < 2:
            return np.zeros(len(centres), bool)
        from slam.frontend.segmentation.artefacts import mirrored_across_nadir

        rc = np.array(centres)
        k = np.round(rc[:, 0]).astype(int)
        port = rc[:, 1] < S - 0.5
        sample = np.clip(np.round(np.where(port, S - 1 - rc[:, 1], rc[:, 1] - S)), 0, S - 1)
        slant = np.array([self.pings[i].slant_range[int(j)] for i, j in zip(k, sample)])
        return mirrored_across_nadir(k, port, slant)

    def _candidates(self, a, S, lab, seg_labels, regions, overlay, rel_db, edge) -> list[Part]:
        """Every region of the window that may be (part of) an object - size, ground-area,
        nadir and first-return-edge tests - as a :class:`Part` in absolute coordinates.
        Marks the overlay."""
        flat_seg = seg_labels.ravel()
        order = np.argsort(flat_seg, kind="stable")
        bounds = np.searchsorted(flat_seg[order], np.arange(int(flat_seg.max(initial=0)) + 2))
        rate = self._ping_rate()
        W2 = seg_labels.shape[1]
        cand = []
        self._long = []  # (port, absolute bbox) of the regions too long to be objects
        for reg in regions:
            if reg.area_px < self.min_area_px:
                continue
            r, c = reg.centroid_rc
            if (
                edge is not None
                and edge[min(round(r), edge.shape[0] - 1), min(round(c), 2 * S - 1)]
            ):
                continue  # the first-return edge / water column is not part of an object
            k = min(a + round(r), len(self.pings) - 1)
            pk = self.pings[k]
            bin_w = float(np.median(np.diff(pk.slant_range)))
            if self.min_area_m2 > 0:  # speckle blobs are small on the ground
                if reg.area_px * bin_w * max(pk.speed, 0.05) / rate < self.min_area_m2:
                    continue
            idx = order[bounds[reg.label] : bounds[reg.label + 1]]
            region_labels = lab.ravel()[idx]
            objs = region_labels[region_labels > 0]
            oid = int(np.bincount(objs).argmax()) if objs.size else 0
            port = c < S - 0.5
            sample = int(np.clip(round((S - 1 - c) if port else (c - S)), 0, S - 1))
            rs = float(pk.slant_range[sample])
            g = float(np.sqrt(max(rs * rs - pk.altitude**2, 0.0)))
            if g < max(self.min_ground_range, 0.5 * pk.altitude):  # nadir band: first return
                continue
            overlay.ravel()[idx] = self.class_of(oid) if oid > 0 else 255
            r0, c0, r1, c1 = reg.bbox
            s0 = (S - c1) if port else (c0 - S)  # nearest sample of the box from nadir
            s1 = (S - 1 - c0) if port else (c1 - 1 - S)
            sl = pk.slant_range[np.clip([s0, s1], 0, S - 1)]
            gi = np.sqrt(np.clip(sl**2 - pk.altitude**2, 0.0, None))
            if self._too_long(r1 - r0, (gi[0], gi[1]), pk.speed, rate):
                self._long.append((bool(port), (a + r0, c0, a + r1, c1)))
                continue
            rows_l, cols = np.divmod(idx, W2)
            prof = row_profile(rows_l, cols, port, S, rel_db, bin_w, self.shadow_config)
            if self.require_shadow and not self._casts_shadow(prof[3]):
                continue  # bright seabed texture: no part of an object standing proud
            cand.append(
                Part(
                    bool(port),
                    np.sort((rows_l + a) * W2 + cols),
                    prof[0] + a,
                    *prof[1:],
                    (a + r0, c0, a + r1, c1),
                    (float(gi[0]), float(gi[1])),
                    oid,
                    objs.size / max(idx.size, 1),
                )
            )
        return cand

    def _casts_shadow(self, sh0: np.ndarray) -> bool:
        """True when at least ``shadow_config.part_shadow_rows`` of a region's rows (its
        profile's shadow starts ``sh0``, -1 = none) have a shadow behind them. With
        ``require_shadow`` a region failing it is no part of any object: on a textured
        seabed, bright texture patches lie closer than ``merge_radius`` to each other and
        to real objects, and single linkage would chain them into one seabed-sized
        "object" (or pull a real one's centre metres off)."""
        return bool(np.mean(sh0 >= 0) >= self.shadow_config.part_shadow_rows)

    def _merge(self, cand: list[Part], rate: float) -> list[list[Part]]:
        """Single linkage of parts on one side whose footprints (along-track x ground
        range, m) lie closer than ``merge_radius``; groups in input order."""
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
                if a_.port != b_.port:
                    continue
                spacing = max(self.pings[min(a_.bbox[0], len(self.pings) - 1)].speed, 0.1) / rate
                gap_al = max(0, max(a_.bbox[0], b_.bbox[0]) - min(a_.bbox[2], b_.bbox[2]))
                gap_g = max(0.0, max(a_.ground[0], b_.ground[0]) - min(a_.ground[1], b_.ground[1]))
                if np.hypot(gap_al * spacing, gap_g) < self.merge_radius:
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


def _overlaps_any(part: Part, boxes: list[tuple[bool, tuple[int, int, int, int]]]) -> bool:
    """True when the part's bbox meets one of the (port, bbox) boxes on its side."""
    r0, c0, r1, c1 = part.bbox
    return any(
        port == part.port and r0 < b[2] and b[0] < r1 and c0 < b[3] and b[1] < c1
        for port, b in boxes
    )

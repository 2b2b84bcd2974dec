"""FLS and MSIS frames -> detections -> SLAM observations (the polar front end).

A forward-looking sonar frame is a polar image (range bins x beams, one pose); an MSIS
scan is a polar image (head angles x range bins) whose rows are pings at their own poses.
Both go through the same chain, :class:`PolarFrontend`:

1. **Conditioning** (:func:`condition_polar`): linear intensity; each cell divided by the
   median of its ``background_window`` neighbourhood (the seabed level changes with range
   and grazing angle); cells without a return set to that level; ``looks`` x ``looks``
   incoherent averaging against speckle; dB above the background mapped with a **fixed**
   scale [0, ``top_db``] dB -> [0, 255] to 8 bits, so bare seabed does not span the full
   grey range and the threshold separates objects from seabed.
2. **Segmentation**: slam.frontend.segmentation (improved Otsu by default) with the size
   rule for the actual image (preset ``"auto"``).
3. **Region filter**: area in [``min_area_px``, ``max_area_fraction`` x image] and a
   contrast test (peak at least ``min_peak_db`` above the local background, CFAR-style);
   regions touching a truncating image edge are dropped (their centroid is not the
   object's).
4. **Extended objects**: regions of one frame whose footprints lie closer than
   ``merge_radius_m`` (single linkage, :func:`footprint_gap_groups`) are one object. Its
   position is the centroid of its cells in metres (body frame, horizontal ranges); its
   covariance is the cell covariance plus the cells' second-moment matrix plus two view
   terms (``extent_bias`` along the major axis, ``shadow_bias`` along the line of
   sight), because a sonar lights only part of an extended object and the landmark is
   its centre. Computed for all regions at once (``numpy.bincount``, batched ``eigh``).
5. **Persistence** (:class:`PersistenceFilter`): a candidate is confirmed when candidates
   lie within ``persistence_radius_m`` (world frame, placed with the *navigation* pose,
   never the true pose) in at least ``persistence_k`` of the last ``persistence_n``
   frames.
6. **Keyframing**: a confirmed detection becomes a SLAM observation only when its track is
   new or the vehicle has moved ``keyframe_distance_m`` / turned ``keyframe_angle_deg``
   since that track's last observation (consecutive frames of one object share their
   systematic error).

Observation timing: an FLS observation belongs to its frame's time; an MSIS observation
to the ping of its centroid row. Persistence uses only past frames, so nothing is
delayed. Why each parameter has its value (measured on the built-in scenarios):
docs/polar-frontend.md.

Hand-written here: the chain's glue, the moment-based covariance and the persistence
filter (no library provides a k-of-n confirmation on world positions); thresholding,
morphology and region labelling are scikit-image / OpenCV / scipy via the front end.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from slam.frontend.polar_parts import (
    PersistenceFilter,
    condition_polar,
    footprint_gap_groups,
    region_moments,
    xy_to_range_bearing,
)
from slam.types import RangeBearing


@dataclass(frozen=True)
class PolarFrontendConfig:
    """Parameters of the FLS / MSIS chain (see the module docstring for each step).

    looks: px, box size of the incoherent average; background_window: px, median window
    of the background estimate; floor: display value (log-compressed [0, 1]) at or below
    which a cell has no return; top_db: dB mapped to grey 255; min_peak_db: dB above
    background a region's peak must reach; min_area_px, max_area_fraction: region size
    limits; merge_radius_m: single-linkage distance joining regions of one object;
    persistence_k of persistence_n frames within persistence_radius_m (world, m);
    keyframe_distance_m / keyframe_angle_deg: vehicle motion between two observations
    of one track (0 = every confirmed detection is an observation); drop_truncated:
    drop regions touching a truncating image edge or reaching within far_margin_m of the
    maximum range (far_truncation_m > 0: keep those, adding far_truncation_m² / 12 to
    the range variance: the object may continue up to that far beyond the range limit);
    shadow_bias: times the region's extent across the line of sight, added as a range
    standard deviation (only the sonar-facing side of an object is lit, its centre lies
    behind it by an unknown depth comparable to its width); extent_bias: times the
    region's length along its major axis, added as a standard deviation along that axis.
    """

    looks: int = 5
    background_window: int = 15
    floor: float = 0.02
    top_db: float = 20.0
    min_peak_db: float = 7.0
    min_area_px: int = 4
    max_area_fraction: float = 0.02
    merge_radius_m: float = 3.0
    persistence_k: int = 3
    persistence_n: int = 5
    persistence_radius_m: float = 1.5
    keyframe_distance_m: float = 2.0
    keyframe_angle_deg: float = 15.0
    drop_truncated: bool = True
    far_margin_m: float = 3.0
    far_truncation_m: float = 0.0
    shadow_bias: float = 0.5
    extent_bias: float = 2.0

    def __post_init__(self) -> None:
        ints = {
            "looks": (self.looks, 1),
            "background_window": (self.background_window, 3),
            "min_area_px": (self.min_area_px, 1),
            "persistence_k": (self.persistence_k, 1),
            "persistence_n": (self.persistence_n, 1),
        }
        for name, (v, lo) in ints.items():
            if not isinstance(v, int | np.integer) or v < lo:
                raise ValueError(f"PolarFrontendConfig.{name} = {v!r}: must be an int >= {lo}")
        if self.persistence_k > self.persistence_n:
            raise ValueError(
                f"PolarFrontendConfig.persistence_k = {self.persistence_k}: must be <= "
                f"persistence_n ({self.persistence_n})"
            )
        pos = {
            "top_db": self.top_db,
            "persistence_radius_m": self.persistence_radius_m,
        }
        for name, v in pos.items():
            if not (np.isfinite(v) and v > 0):
                raise ValueError(f"PolarFrontendConfig.{name} = {v!r}: must be finite and > 0")
        nonneg = {
            "floor": self.floor,
            "min_peak_db": self.min_peak_db,
            "merge_radius_m": self.merge_radius_m,
            "keyframe_distance_m": self.keyframe_distance_m,
            "keyframe_angle_deg": self.keyframe_angle_deg,
            "far_margin_m": self.far_margin_m,
            "far_truncation_m": self.far_truncation_m,
            "shadow_bias": self.shadow_bias,
            "extent_bias": self.extent_bias,
        }
        for name, v in nonneg.items():
            if not (np.isfinite(v) and v >= 0):
                raise ValueError(f"PolarFrontendConfig.{name} = {v!r}: must be finite and >= 0")
        if not 0 < self.max_area_fraction <= 1:
            raise ValueError(
                f"PolarFrontendConfig.max_area_fraction = {self.max_area_fraction!r}: "
                "allowed (0, 1]"
            )


#: FLS: 5 x 5 looks; an object must recur in 3 of 5 frames (0.6 of 1 s at 5 Hz) within
#: 1.5 m; a new observation of a track every 2 m or 15 deg of vehicle motion.
FLS_FRONTEND = PolarFrontendConfig()
#: MSIS: a scan takes 360 / (step x ping rate) s (14 s for the default head), so
#: persistence is 2 of 2 scans within 3 m (the vehicle's dead reckoning drifts little in
#: one scan; an extended object's centroid moves with the view); 3 x 3 looks (an MSIS
#: row is one ping, averaging 5 rows blurs 9 deg); 360 deg scans have no angular edge.
MSIS_FRONTEND = PolarFrontendConfig(
    looks=3,
    persistence_k=2,
    persistence_n=2,
    persistence_radius_m=3.0,
    keyframe_distance_m=0.0,
    keyframe_angle_deg=0.0,
)


@dataclass(frozen=True)
class PolarDetection:
    """One object found in a polar frame (after merging regions of one object).

    observation: RangeBearing in the body frame of the pose at ``row`` (its ``t``);
    row: image row of its centroid (MSIS: the ping; FLS: the range bin); world_xy_nav:
    placed with the navigation pose; area_px: cells; group: label in ``PolarResult.groups``;
    confirmed: passed persistence; emitted: fed to SLAM (keyframe)."""

    observation: RangeBearing
    row: int
    world_xy_nav: np.ndarray
    area_px: int
    group: int
    confirmed: bool
    emitted: bool


@dataclass(frozen=True)
class PolarResult:
    """One processed frame: ``groups`` (H, W) int32 object label per cell (0 none;
    detection i has label i + 1), its detections, and counts of regions per stage."""

    groups: np.ndarray
    detections: list[PolarDetection]
    n_regions: int
    n_candidates: int


class PolarFrontend:
    """The chain of the module docstring for one FLS or MSIS sonar.

    layout "fls": image (n_bins, n_beams), ``angles`` the beam bearings (n_beams,) rad;
    layout "msis": image (n_angles, n_bins), ``angles`` the head angle of each row.
    ranges: (n_bins,) m bin centres (slant); bin_width m; angular_cell: rad, the
    angular resolution (max of beam width and beam / step spacing). mount_xy: m, the
    sonar's position in the vehicle body frame (x forward, y port); observations are
    expressed from the vehicle origin.
    segment(gray8) -> (labels, regions) is the front end's segmentation adapter.
    """

    def __init__(
        self,
        layout: str,
        segment: Callable[[np.ndarray], tuple[np.ndarray, list]],
        *,
        ranges: np.ndarray,
        angles: np.ndarray,
        bin_width: float,
        angular_cell: float,
        log_compressed: bool,
        dynamic_range_db: float,
        config: PolarFrontendConfig,
        mount_xy: tuple[float, float] = (0.0, 0.0),
    ) -> None:
        if layout not in ("fls", "msis"):
            raise ValueError(f"layout = {layout!r}: allowed 'fls' or 'msis'")
        self.layout = layout
        self.segment = segment
        self.ranges = np.asarray(ranges, float)
        self.angles = np.asarray(angles, float)
        self.bin_width = float(bin_width)
        self.angular_cell = float(angular_cell)
        self.mount_xy = (float(mount_xy[0]), float(mount_xy[1]))
        d = np.abs(np.diff(self.angles))
        self.angular_spacing = float(np.median(d)) if d.size else self.angular_cell
        self.log_compressed = bool(log_compressed)
        self.dynamic_range_db = float(dynamic_range_db)
        self.cfg = c = config
        self.persistence = PersistenceFilter(
            c.persistence_k,
            c.persistence_n,
            c.persistence_radius_m,
            track_radius=max(c.merge_radius_m, c.persistence_radius_m),
            keyframe_distance=c.keyframe_distance_m,
            keyframe_angle=np.radians(c.keyframe_angle_deg),
        )

    def _grid(self, shape):
        """(slant range, angle) per cell, broadcast to the image shape."""
        if self.layout == "fls":
            return np.broadcast_to(self.ranges[:, None], shape), np.broadcast_to(
                self.angles[None, :], shape
            )
        return np.broadcast_to(self.ranges[None, :], shape), np.broadcast_to(
            self.angles[:, None], shape
        )

    def _edges(self, shape) -> np.ndarray:
        e = np.zeros(shape, bool)
        if self.layout == "fls":
            e[-1, :] = True
            e[:, 0] = e[:, -1] = True
        else:
            e[:, -1] = True
        return e

    def process(
        self,
        image: np.ndarray,
        *,
        altitude: float | None,
        poses_nav: np.ndarray,
        times: np.ndarray,
    ) -> PolarResult:
        """One frame. altitude: m above the seabed for slant -> horizontal range (None:
        slant = horizontal). poses_nav: (3,) or (rows, 3) navigation pose [x, y, yaw] of
        the frame (FLS) or of each row (MSIS); times: scalar or (rows,) s likewise."""
        c = self.cfg
        g8, db = condition_polar(
            image,
            log_compressed=self.log_compressed,
            dynamic_range_db=self.dynamic_range_db,
            cfg=c,
        )
        labels, regions = self.segment(g8)
        labels = np.asarray(labels)
        empty = PolarResult(np.zeros(labels.shape, np.int32), [], len(regions), 0)
        kept = self._kept_regions(labels, db)
        if kept is None:
            return empty
        ids, at_far = kept
        alt = float(altitude) if altitude is not None and np.isfinite(altitude) else 0.0
        groups, grp, xy, M, cnt, rc = self._objects(labels, ids, alt)
        g_far = np.bincount(grp, at_far[ids].astype(float), len(xy)) > 0
        M, var_r, var_t = self._object_covariance(xy, M, alt, g_far)
        dets = self._detections(xy, M, var_r, var_t, cnt, rc, poses_nav, times)
        return PolarResult(groups, dets, len(regions), len(dets))

    def _kept_regions(self, labels: np.ndarray, db: np.ndarray):
        """Step 3: (ids of the regions kept, at_far (n + 1,) bool: reaching the far
        margin), or None when none is kept."""
        c = self.cfg
        n_lab = int(labels.max()) if labels.size else 0
        if n_lab == 0:
            return None
        area = np.bincount(labels.ravel(), minlength=n_lab + 1)
        peak = np.full(n_lab + 1, -np.inf)
        peak[1:] = ndimage.maximum(db, labels, np.arange(1, n_lab + 1))
        keep = (area >= c.min_area_px) & (area <= c.max_area_fraction * labels.size)
        keep &= peak >= c.min_peak_db
        keep[0] = False
        if c.drop_truncated:
            slant, _ = self._grid(labels.shape)
            keep[np.unique(labels[self._edges(labels.shape)])] = False
            far = np.zeros(n_lab + 1)
            far[1:] = ndimage.maximum(slant, labels, np.arange(1, n_lab + 1))
            at_far = far > self.ranges[-1] + 0.5 * self.bin_width - c.far_margin_m
            if c.far_truncation_m <= 0:
                keep &= ~at_far
        else:
            at_far = np.zeros(n_lab + 1, bool)
        ids = np.flatnonzero(keep)
        return (ids, at_far) if ids.size else None

    def _objects(self, labels: np.ndarray, ids: np.ndarray, alt: float):
        """Step 4: kept regions merged into objects. Returns the object label image, the
        object of each kept region, and per object its centroid (m, body), second moments,
        cell count and centroid row."""
        slant, ang = self._grid(labels.shape)
        # body coordinates of every cell (horizontal range on a flat seabed)
        horiz = np.sqrt(np.clip(slant**2 - alt**2, 0.0, None))
        bx = horiz * np.cos(ang) + self.mount_xy[0]
        by = horiz * np.sin(ang) + self.mount_xy[1]
        remap = np.zeros(int(labels.max()) + 1, np.int64)
        remap[ids] = np.arange(1, ids.size + 1)
        lab_k = remap[labels]
        cen, Mk, _ = region_moments(lab_k, ids.size, bx, by)
        # one object = regions whose footprints lie within merge_radius (body frame)
        grp = footprint_gap_groups(cen, Mk, self.cfg.merge_radius_m)
        ng = int(grp.max()) + 1
        gmap = np.concatenate([[0], grp + 1])
        groups = gmap[lab_k].astype(np.int32)
        xy, M, cnt = region_moments(groups, ng, bx, by)
        rows_of = np.arange(labels.shape[0])[:, None] * np.ones((1, labels.shape[1]))
        row_c = np.bincount(groups.ravel(), rows_of.ravel(), ng + 1)[1:] / cnt
        rc = np.clip(np.round(row_c).astype(int), 0, labels.shape[0] - 1)
        return groups, grp, xy, M, cnt, rc

    def _object_covariance(self, xy, M, alt: float, g_far):
        """Step 4's covariance: cell variances in native polar coordinates (uniform over a
        cell, slant -> horizontal) and the view terms. Returns (M with the extent term,
        range variance, bearing variance)."""
        c = self.cfg
        ng = len(xy)
        rho_c = np.hypot(xy[:, 0], xy[:, 1])
        s_c = np.sqrt(rho_c**2 + alt**2)
        dr = s_c / np.maximum(rho_c, 1e-9)
        var_r = (dr * self.bin_width) ** 2 / 12.0
        var_t = np.full(ng, self.angular_cell**2 / 12.0)
        # an object's own length along an axis: that of the region (sqrt(12 var), a uniform
        # bar) less the width a point target's region gets from the chain: in range
        # looks - 1 bins of box blur + 2 of the size rule's one 3 x 3 dilation; across,
        # the same in beams / head steps plus the angular resolution (beam width)
        grow_r = (c.looks + 1) * self.bin_width * dr
        grow_t = rho_c * ((c.looks + 1) * self.angular_spacing + self.angular_cell)
        e_r = xy / np.maximum(rho_c, 1e-9)[:, None]  # line-of-sight unit vectors

        def grow(u: np.ndarray) -> np.ndarray:
            cr = np.einsum("ni,ni->n", u, e_r)
            return np.sqrt((cr * grow_r) ** 2 + (1.0 - cr**2) * grow_t**2)

        M_view = M
        if c.extent_bias > 0:  # the lit part of an extended object: centre unknown along it
            lam, vec = np.linalg.eigh(M)
            u = vec[:, :, 1]
            length = np.maximum(np.sqrt(12.0 * np.maximum(lam[:, 1], 0.0)) - grow(u), 0.0)
            M_view = M + ((c.extent_bias * length) ** 2)[:, None, None] * (
                u[:, :, None] * u[:, None, :]
            )
        if c.far_truncation_m > 0:
            var_r = var_r + g_far * c.far_truncation_m**2 / 12.0
        if c.shadow_bias > 0:
            u = np.column_stack([-xy[:, 1], xy[:, 0]]) / np.maximum(rho_c, 1e-9)[:, None]
            var_across = np.maximum(np.einsum("ni,nij,nj->n", u, M, u), 0.0)
            width = np.maximum(np.sqrt(12.0 * var_across) - grow(u), 0.0)
            var_r = var_r + (c.shadow_bias * width) ** 2
        return M_view, var_r, var_t

    def _detections(self, xy, M, var_r, var_t, cnt, rc, poses_nav, times):
        """Steps 4-6 closed: range-bearing observations at the frame's / the centroid
        ping's pose and time, persistence and keyframing."""
        ok = np.hypot(xy[:, 0], xy[:, 1]) > 0
        r, b, R = xy_to_range_bearing(xy[ok], M[ok], var_r[ok], var_t[ok])
        gidx = np.flatnonzero(ok)
        poses = np.asarray(poses_nav, float)
        times = np.asarray(times, float)
        if self.layout == "msis":
            P = poses.reshape(-1, 3)[rc[gidx]]
            T = times.reshape(-1)[rc[gidx]]
        else:
            P = np.broadcast_to(poses.reshape(3), (len(gidx), 3))
            T = np.broadcast_to(times.reshape(()), (len(gidx),))
        a = P[:, 2] + b
        wxy = P[:, :2] + r[:, None] * np.column_stack([np.cos(a), np.sin(a)])
        # persistence runs on the frame's pose (FLS) / the scan's last pose (MSIS)
        confirmed, emit = self.persistence.step(wxy, poses.reshape(-1, 3)[-1])
        return [
            PolarDetection(
                RangeBearing(
                    np.array([r[n], b[n]]),
                    R[n],
                    t=float(T[n]),
                    meta={"group": int(g + 1), "area_px": int(cnt[g])},
                ),
                int(rc[g]),
                wxy[n],
                int(cnt[g]),
                int(g + 1),
                bool(confirmed[n]),
                bool(emit[n]),
            )
            for n, g in enumerate(gidx)
        ]

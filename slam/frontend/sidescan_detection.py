"""One side-scan object -> one Detection (a SLAM range-bearing observation).

Each detection is tied to the ping k nearest its centre (time t_k). An object that
casts a shadow is located at its centre from highlight + shadow
(slam.frontend.extended_objects.object_centre: across-track midpoint between the near
edge and the top's far edge, the height from the shadow's length), with a covariance
that says how well that centre is known. Without a shadow (or without the ``shadow``
callable), the observation comes from the highlight's centroid through the side-scan
observation model (slam.frontend.observation.range_bearing_from_pixels: ground range
sqrt(r^2 - h^2), bearing ~ +90 deg (port) / -90 deg (starboard) from the pose at ping
k, covariance from cell sizes and the region's extent) plus a view-dependent term: the
highlight is the sonar-facing part of the object, so ``view_bias`` x its across-track
extent (range) and along-track extent (as a bearing) are added as standard deviations
(0.5: half the extent). Detections centred in the water column give no observation.
slam.pipeline feeds each to SLAM at the pose of t_k (slam.pipeline.lagged).
"""

from __future__ import annotations

import numpy as np

from slam.frontend.extended_objects import Part, object_centre
from slam.frontend.observation import (
    SideScanGeometry,
    range_bearing_from_pixels,
    xy_cov_to_range_bearing,
)
from slam.frontend.sidescan_records import Detection, PingRecord, placing_pose
from slam.types import RangeBearing


def object_detection(
    obj: Part,
    row: float,
    col: float,
    S: int,
    rate: float,
    pings: list[PingRecord],
    *,
    use_shadow: bool,
    require_shadow: bool,
    altitude_sigma: float,
    along_track_beamwidth_deg: float,
    view_bias: float,
    tp_fraction: float,
) -> Detection | None:
    """The Detection of one object: its centre from highlight and shadow
    (slam.frontend.extended_objects) when it casts one, else its highlight's
    centroid with the view-dependent term; None in the water column (and None without
    a shadow when ``require_shadow``).

    obj: the merged object; row, col: its pixel centroid (absolute ping, column of the
    (pings, 2S) waterfall); rate: ping rate, Hz; pings: every ping so far. The keyword
    arguments are SidescanProcessor's settings of the same names (``use_shadow``: it
    has the shadow callable).
    """
    k = round(row)
    p = pings[k]
    bin_w = float(np.median(np.diff(p.slant_range))) if len(p.slant_range) > 1 else 0.05
    spacing = max(p.speed, 0.05) / rate
    alts = np.array([pings[int(i)].altitude for i in obj.rows])
    centre = (
        object_centre(
            obj,
            p.slant_range,
            alts,
            bin_w,
            altitude_sigma=altitude_sigma,
            end_sigma_rows=max(
                1.0,
                float(0.5 * sum(obj.ground) * np.radians(along_track_beamwidth_deg)) / spacing,
            ),
        )
        if use_shadow
        else None
    )
    if centre is not None:
        k = min(max(round(centre.row), 0), len(pings) - 1)
        p = pings[k]
        sign = 1.0 if obj.port else -1.0
        x = np.array([(centre.row - k) * spacing])
        y = np.array([sign * centre.ground])
        rho, brg, cov = xy_cov_to_range_bearing(
            x, y, np.array([centre.var_rows * spacing**2]), np.array([centre.var_ground])
        )
        rng_, R = rho, cov[0]
    elif require_shadow:
        return None
    else:
        ext = (obj.bbox[2] - obj.bbox[0], obj.bbox[3] - obj.bbox[1])
        geom = SideScanGeometry(
            slant_range_max=float(p.slant_range[-1] + bin_w / 2),
            samples_per_side=S,
            altitude=max(float(p.altitude), 0.0),
            along_track_spacing=spacing,
            slant_range_min=max(float(p.slant_range[0] - bin_w / 2), 0.0),
            along_track_beamwidth_deg=along_track_beamwidth_deg,
            altitude_sigma=altitude_sigma,
        )
        try:
            rng_, brg, cov = range_bearing_from_pixels(
                geom, np.array([[row - k, col]]), np.array([ext]), ref_row=0.0
            )
        except ValueError:  # centroid in the water column (no ground range)
            return None
        R = cov[0].copy()
        if view_bias > 0:  # the highlight's place on the object depends on the view
            R[0, 0] += (view_bias * ext[1] * bin_w) ** 2
            R[1, 1] += (view_bias * ext[0] * spacing / max(rng_[0], 1.0)) ** 2
    obs = RangeBearing([rng_[0], brg[0]], R, t=p.t, meta={"object_id": obj.oid, "ping": k})
    x0, y0, yaw = placing_pose(p)
    wxy = np.array([x0 + rng_[0] * np.cos(yaw + brg[0]), y0 + rng_[0] * np.sin(yaw + brg[0])])
    return Detection(
        p.t,
        k,
        "port" if obj.port else "starboard",
        float(np.hypot(rng_[0], p.altitude)),
        float(rng_[0]),
        obj.area_px,
        obs,
        obj.oid,
        obj.frac >= tp_fraction,
        wxy,
    )

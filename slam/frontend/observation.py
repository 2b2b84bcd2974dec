"""Observation model: a detection's pixel centroid → (range, bearing) in the vehicle body
frame with a covariance from the sonar geometry and the region's extent.

Frames (ARCHITECTURE.md): body x forward, y port; bearing counter-clockwise from body x,
radians in (−π, π]; ranges in m, horizontal (projected onto the seabed plane when an
altitude is given). Pixel coordinates are (row, col) with pixel centres at integers.

Image layouts (the geometry dataclasses below, frozen; ``slam`` never imports ``sim``):

* **Side-scan waterfall** (:class:`SideScanGeometry`), shape (pings, 2·S): port left with
  its far range at column 0, starboard right with its far range at column 2S − 1, nadir
  between columns S − 1 and S; row = ping, increasing with time (later pings lie ahead).
  Sample i (from nadir) spans slant ranges [r_min + i·Δr, r_min + (i+1)·Δr),
  Δr = (r_max − r_min)/S. Ground range g = sqrt(r² − h²) (flat seabed, altitude h).
  Body position of a detection at row ρ seen from the vehicle at ping ``ref_row``:
  x = (ρ − ref_row)·Δa (Δa = along-track spacing), y = +g (port) or −g (starboard),
  so the bearing is +90° / −90° when ``ref_row`` is the detection's own ping.
* **FLS, polar** (:class:`FLSGeometry`, ``layout="polar"``), shape (n_bins, n_beams): row =
  range bin (row 0 nearest), column = beam, beam j centred at
  θ_j = +fov/2 − (j + ½)·fov/n_beams (column 0 is the port edge, as displayed).
* **FLS, Cartesian fan** (``layout="cartesian"``), shape (H, W): square pixels of size
  res (default r_max / H), pixel (i, j) centred at x = r_max − (i + ½)·res forward and
  y = y_max − (j + ½)·res to port (default y_max = W·res/2: the sonar at the middle of the
  bottom edge); the simulator's ``sim.sonar.fls.FanImage`` convention.
* **MSIS** (:class:`MSISGeometry`), shape (n_steps, n_bins): row k = head angle
  θ_k = sector_centre − sector/2 + k·step (ccw from body x; the simulator's
  ``MSISSonar.head_angles``), column = range bin. Fractional rows interpolate linearly.

Covariance: every native coordinate (slant range, along-track position, beam angle, pixel
x/y) is uncertain by its cell size and by the region's extent, each modelled as a uniform
distribution (variance = width²/12, summed), plus the beam width where the beam is wider
than a cell; the altitude uncertainty enters the ground range. The (x, y) or (r, θ)
covariance is propagated to (range, bearing) with the Jacobian (first order).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slam.types import RangeBearing, wrap_angle


def _pos(name: str, v: float, *, zero_ok: bool = False) -> None:
    if not np.isfinite(v) or v < 0 or (v == 0 and not zero_ok):
        raise ValueError(f"{name} = {v!r}: must be finite and {'>= 0' if zero_ok else '> 0'}")


@dataclass(frozen=True)
class SideScanGeometry:
    """slant_range_max / slant_range_min: m (sample ranges); samples_per_side: S;
    altitude: m above a flat seabed; along_track_spacing: m between pings (speed / ping
    rate); along_track_beamwidth_deg: horizontal −3 dB beam width (footprint grows with
    range); altitude_sigma: m, 1-σ altitude error; transducer_y: m, lateral lever arm of
    the transducers (port at +transducer_y, starboard at −transducer_y in the body frame)."""

    slant_range_max: float
    samples_per_side: int
    altitude: float
    along_track_spacing: float
    slant_range_min: float = 0.0
    along_track_beamwidth_deg: float = 0.0
    altitude_sigma: float = 0.0
    transducer_y: float = 0.0

    def __post_init__(self) -> None:
        _pos("slant_range_max", self.slant_range_max)
        _pos("transducer_y", self.transducer_y, zero_ok=True)
        _pos("slant_range_min", self.slant_range_min, zero_ok=True)
        if self.slant_range_min >= self.slant_range_max:
            raise ValueError(
                f"slant_range_min {self.slant_range_min} must be < slant_range_max {self.slant_range_max}"
            )
        if not isinstance(self.samples_per_side, int | np.integer) or self.samples_per_side < 1:
            raise ValueError(f"samples_per_side = {self.samples_per_side!r}: must be an int >= 1")
        _pos("altitude", self.altitude, zero_ok=True)
        _pos("along_track_spacing", self.along_track_spacing)
        _pos("along_track_beamwidth_deg", self.along_track_beamwidth_deg, zero_ok=True)
        _pos("altitude_sigma", self.altitude_sigma, zero_ok=True)

    @property
    def bin_width(self) -> float:
        return (self.slant_range_max - self.slant_range_min) / self.samples_per_side


@dataclass(frozen=True)
class FLSGeometry:
    """range_max / range_min: m; n_bins, n_beams: polar image size; horizontal_fov_deg;
    beamwidth_deg: one beam's −3 dB width; layout: "polar" or "cartesian"; image_shape:
    (H, W) of a Cartesian fan image (required for that layout); altitude: m above the
    seabed for projecting slant to horizontal range (None: targets at sonar depth, slant =
    horizontal); fan_resolution, fan_y_max: Cartesian fan pixel size and port edge, m
    (defaults range_max / H and W·res / 2)."""

    range_max: float
    n_bins: int = 0
    n_beams: int = 0
    horizontal_fov_deg: float = 90.0
    beamwidth_deg: float = 1.0
    range_min: float = 0.0
    layout: str = "polar"
    image_shape: tuple[int, int] | None = None
    altitude: float | None = None
    fan_resolution: float | None = None
    fan_y_max: float | None = None

    def __post_init__(self) -> None:
        _pos("range_max", self.range_max)
        _pos("range_min", self.range_min, zero_ok=True)
        if self.range_min >= self.range_max:
            raise ValueError(f"range_min {self.range_min} must be < range_max {self.range_max}")
        if self.fan_resolution is not None:
            _pos("fan_resolution", self.fan_resolution)
        if self.fan_y_max is not None:
            _pos("fan_y_max", self.fan_y_max)
        if not 0 < self.horizontal_fov_deg <= 360:
            raise ValueError(f"horizontal_fov_deg = {self.horizontal_fov_deg}: allowed (0, 360]")
        _pos("beamwidth_deg", self.beamwidth_deg, zero_ok=True)
        if self.layout == "polar":
            if self.n_bins < 1 or self.n_beams < 1:
                raise ValueError(
                    f"polar FLS needs n_bins >= 1 and n_beams >= 1, got {self.n_bins}, {self.n_beams}"
                )
        elif self.layout == "cartesian":
            if self.image_shape is None or min(self.image_shape) < 1:
                raise ValueError(
                    f"cartesian FLS needs image_shape (H, W) >= 1, got {self.image_shape}"
                )
        else:
            raise ValueError(f"layout = {self.layout!r}: allowed 'polar' or 'cartesian'")
        if self.altitude is not None:
            _pos("altitude", self.altitude, zero_ok=True)

    @property
    def bin_width(self) -> float:
        return (self.range_max - self.range_min) / self.n_bins

    @property
    def beam_spacing(self) -> float:
        """rad between polar beam centres."""
        return np.radians(self.horizontal_fov_deg) / self.n_beams

    @property
    def pixel_size(self) -> float:
        """m per pixel of the Cartesian fan image."""
        if self.fan_resolution is not None:
            return float(self.fan_resolution)
        return self.range_max / self.image_shape[0]

    @property
    def y_max(self) -> float:
        """m, lateral (port) coordinate of the fan image's left edge."""
        if self.fan_y_max is not None:
            return float(self.fan_y_max)
        return self.image_shape[1] * self.pixel_size / 2.0


@dataclass(frozen=True)
class MSISGeometry:
    """range_max / range_min: m; n_bins: range bins; step_deg: head step per row;
    sector_deg, sector_center_deg: scanned sector (ccw from body x); beamwidth_deg:
    horizontal −3 dB width; altitude: as for FLSGeometry."""

    range_max: float
    n_bins: int
    step_deg: float
    sector_deg: float = 360.0
    sector_center_deg: float = 0.0
    beamwidth_deg: float = 3.0
    range_min: float = 0.0
    altitude: float | None = None

    def __post_init__(self) -> None:
        _pos("range_max", self.range_max)
        _pos("range_min", self.range_min, zero_ok=True)
        if self.range_min >= self.range_max:
            raise ValueError(f"range_min {self.range_min} must be < range_max {self.range_max}")
        if self.n_bins < 1:
            raise ValueError(f"n_bins = {self.n_bins}: must be >= 1")
        _pos("step_deg", self.step_deg)
        if not 0 < self.sector_deg <= 360:
            raise ValueError(f"sector_deg = {self.sector_deg}: allowed (0, 360]")
        _pos("beamwidth_deg", self.beamwidth_deg, zero_ok=True)
        if self.altitude is not None:
            _pos("altitude", self.altitude, zero_ok=True)

    @property
    def bin_width(self) -> float:
        return (self.range_max - self.range_min) / self.n_bins


Geometry = SideScanGeometry | FLSGeometry | MSISGeometry


def _as_rc(centroid_rc, extent_rc) -> tuple[np.ndarray, np.ndarray]:
    c = np.asarray(centroid_rc, dtype=np.float64)
    e = np.broadcast_to(np.asarray(extent_rc, dtype=np.float64), c.shape)
    if c.ndim != 2 or c.shape[1] != 2:
        raise ValueError(f"centroids must have shape (N, 2) (row, col), got {c.shape}")
    if not (np.all(np.isfinite(c)) and np.all(np.isfinite(e))) or np.any(e < 0):
        raise ValueError("centroids must be finite and extents finite and >= 0")
    return c, e


def _horizontal(
    slant: np.ndarray, altitude: float | None, what: str
) -> tuple[np.ndarray, np.ndarray]:
    """(horizontal range, d horizontal / d slant)."""
    if altitude is None or altitude == 0:
        return slant, np.ones_like(slant)
    if np.any(slant <= altitude):
        bad = float(slant[slant <= altitude][0])
        raise ValueError(
            f"{what}: slant range {bad:.3f} m <= altitude {altitude} m (water column): no ground range"
        )
    g = np.sqrt(slant**2 - altitude**2)
    return g, slant / g


def xy_cov_to_range_bearing(x, y, vxx, vyy, vxy=0.0):
    """Body (x, y) m with variances (vxx, vyy, covariance vxy), arrays of one shape ->
    (range m, bearing rad, (..., 2, 2) covariance of [range, bearing]), first order."""
    rho = np.hypot(x, y)
    if np.any(rho <= 0):
        raise ValueError("detection at the sonar origin (range 0): bearing undefined")
    j = np.zeros((*x.shape, 2, 2))
    j[..., 0, 0], j[..., 0, 1] = x / rho, y / rho
    j[..., 1, 0], j[..., 1, 1] = -y / rho**2, x / rho**2
    s = np.zeros((*x.shape, 2, 2))
    s[..., 0, 0], s[..., 1, 1] = vxx, vyy
    s[..., 0, 1] = s[..., 1, 0] = vxy
    return rho, np.arctan2(y, x), j @ s @ np.swapaxes(j, -1, -2)


def _sss(g: SideScanGeometry, c: np.ndarray, e: np.ndarray, ref_row):
    s = g.samples_per_side
    row, col = c[:, 0], c[:, 1]
    if np.any(col < -0.5) or np.any(col > 2 * s - 0.5):
        raise ValueError(f"side-scan column outside [-0.5, {2 * s - 0.5}]: {col.tolist()}")
    port = col < s - 0.5
    u = np.where(port, (s - 1) - col, col - s)  # sample index from nadir (pixel centres)
    slant = g.slant_range_min + (u + 0.5) * g.bin_width
    ground, dg_dr = _horizontal(slant, g.altitude, "side-scan detection")
    var_r = (g.bin_width**2) * (1.0 + e[:, 1] ** 2) / 12.0
    var_g = dg_dr**2 * var_r + (g.altitude / ground) ** 2 * g.altitude_sigma**2
    ref = row if ref_row is None else np.broadcast_to(np.asarray(ref_row, float), row.shape)
    x = (row - ref) * g.along_track_spacing
    y = np.where(port, ground + g.transducer_y, -ground - g.transducer_y)
    foot = slant * np.radians(g.along_track_beamwidth_deg)
    var_x = (g.along_track_spacing**2 * (1.0 + e[:, 0] ** 2) + foot**2) / 12.0
    return xy_cov_to_range_bearing(x, y, var_x, var_g)


def _polar(slant, theta, var_slant, var_theta, altitude, what):
    rho, drho = _horizontal(slant, altitude, what)
    cov = np.zeros((*slant.shape, 2, 2))
    cov[:, 0, 0] = drho**2 * var_slant
    cov[:, 1, 1] = var_theta
    return rho, theta, cov


def _fls(g: FLSGeometry, c: np.ndarray, e: np.ndarray):
    bw = np.radians(g.beamwidth_deg)
    if g.layout == "polar":
        i, j = c[:, 0], c[:, 1]
        if (
            np.any(i < -0.5)
            or np.any(i > g.n_bins - 0.5)
            or np.any(j < -0.5)
            or np.any(j > g.n_beams - 0.5)
        ):
            raise ValueError(f"FLS centroid outside the {g.n_bins}×{g.n_beams} polar image")
        half = np.radians(g.horizontal_fov_deg) / 2.0
        slant = g.range_min + (i + 0.5) * g.bin_width
        theta = half - (j + 0.5) * g.beam_spacing
        var_r = g.bin_width**2 * (1.0 + e[:, 0] ** 2) / 12.0
        var_t = (max(bw, g.beam_spacing) ** 2 + (e[:, 1] * g.beam_spacing) ** 2) / 12.0
        return _polar(slant, theta, var_r, var_t, g.altitude, "FLS detection")
    ps = g.pixel_size
    x = g.range_max - (c[:, 0] + 0.5) * ps
    y = g.y_max - (c[:, 1] + 0.5) * ps
    vx = ps**2 * (1.0 + e[:, 0] ** 2) / 12.0
    vy = ps**2 * (1.0 + e[:, 1] ** 2) / 12.0
    slant, theta, cov = xy_cov_to_range_bearing(x, y, vx, vy)
    cov[:, 1, 1] += bw**2 / 12.0
    rho, drho = _horizontal(slant, g.altitude, "FLS detection")
    cov[:, 0, 0] *= drho**2
    cov[:, 0, 1] *= drho
    cov[:, 1, 0] *= drho
    return rho, theta, cov


def _msis_angles(g: MSISGeometry, k: np.ndarray) -> np.ndarray:
    return np.radians(g.sector_center_deg - g.sector_deg / 2.0 + k * g.step_deg)


def _msis(g: MSISGeometry, c: np.ndarray, e: np.ndarray):
    k, i = c[:, 0], c[:, 1]
    if np.any(i < -0.5) or np.any(i > g.n_bins - 0.5):
        raise ValueError(f"MSIS range bin outside [-0.5, {g.n_bins - 0.5}]")
    slant = g.range_min + (i + 0.5) * g.bin_width
    theta = _msis_angles(g, k)
    step = np.radians(g.step_deg)
    var_r = g.bin_width**2 * (1.0 + e[:, 1] ** 2) / 12.0
    var_t = (max(np.radians(g.beamwidth_deg), step) ** 2 + (e[:, 0] * step) ** 2) / 12.0
    return _polar(slant, theta, var_r, var_t, g.altitude, "MSIS detection")


def range_bearing_from_pixels(
    geometry: Geometry,
    centroids_rc: np.ndarray,
    extents_rc: np.ndarray | tuple[float, float] = (1.0, 1.0),
    *,
    ref_row: float | np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vectorized core: (N, 2) pixel centroids (row, col) and region extents in pixels
    (rows, cols; e.g. the bounding-box size) → (range (N,), bearing (N,), cov (N, 2, 2)).

    ``ref_row`` (side-scan only): the ping row of the vehicle pose the observation refers
    to (default: each detection's own row). Raises ValueError for centroids outside the
    image or inside the water column.
    """
    c, e = _as_rc(np.atleast_2d(centroids_rc), extents_rc)
    if isinstance(geometry, SideScanGeometry):
        r, b, cov = _sss(geometry, c, e, ref_row)
    elif isinstance(geometry, FLSGeometry):
        r, b, cov = _fls(geometry, c, e)
    elif isinstance(geometry, MSISGeometry):
        r, b, cov = _msis(geometry, c, e)
    else:
        raise ValueError(f"unknown geometry type {type(geometry).__name__}")
    return r, np.asarray(wrap_angle(b), dtype=np.float64).reshape(r.shape), cov


def observe(
    geometry: Geometry,
    centroid_rc: tuple[float, float],
    extent_rc: tuple[float, float] = (1.0, 1.0),
    *,
    t: float = 0.0,
    label: int | None = None,
    ref_row: float | None = None,
) -> RangeBearing:
    """One detection → :class:`slam.types.RangeBearing` (z = [range m, bearing rad], R)."""
    r, b, cov = range_bearing_from_pixels(
        geometry, np.asarray([centroid_rc]), extent_rc, ref_row=ref_row
    )
    return RangeBearing(
        z=np.array([r[0], b[0]]),
        R=cov[0],
        t=t,
        label=label,
        meta={
            "centroid_rc": tuple(map(float, centroid_rc)),
            "extent_rc": tuple(map(float, extent_rc)),
        },
    )


def observe_regions(
    geometry: Geometry,
    centroids_rc: np.ndarray,
    extents_rc: np.ndarray,
    *,
    t: float = 0.0,
    ref_row: float | None = None,
    on_invalid: str = "raise",
) -> list[RangeBearing]:
    """Many detections at once (vectorized maths) → list of RangeBearing.

    ``on_invalid="skip"`` drops detections that have no observation (outside the image,
    in the water column, at the origin) instead of raising; the kept ones carry their
    input index in ``meta["index"]``.
    """
    if on_invalid not in ("raise", "skip"):
        raise ValueError(f"on_invalid must be 'raise' or 'skip', got {on_invalid!r}")
    c = np.asarray(centroids_rc, dtype=np.float64).reshape(-1, 2)
    e = np.broadcast_to(np.asarray(extents_rc, dtype=np.float64), c.shape)
    if c.shape[0] == 0:
        return []
    try:
        r, b, cov = range_bearing_from_pixels(geometry, c, e, ref_row=ref_row)
        keep = np.arange(c.shape[0])
    except ValueError:
        if on_invalid == "raise":
            raise
        ok = []
        for k in range(c.shape[0]):  # rare path: find the valid detections one by one
            try:
                range_bearing_from_pixels(geometry, c[k : k + 1], e[k : k + 1], ref_row=ref_row)
                ok.append(k)
            except ValueError:
                pass
        keep = np.asarray(ok, dtype=int)
        if keep.size == 0:
            return []
        rr = None if ref_row is None or np.ndim(ref_row) == 0 else np.asarray(ref_row)[keep]
        r, b, cov = range_bearing_from_pixels(
            geometry, c[keep], e[keep], ref_row=ref_row if rr is None else rr
        )
    return [
        RangeBearing(
            z=np.array([r[n], b[n]]),
            R=cov[n],
            t=t,
            meta={"centroid_rc": tuple(c[k]), "extent_rc": tuple(e[k]), "index": int(k)},
        )
        for n, k in enumerate(keep)
    ]


def body_xy(z: np.ndarray) -> np.ndarray:
    """(…, 2) [range, bearing] → (…, 2) body-frame [x forward, y port], m."""
    z = np.asarray(z, dtype=np.float64)
    return np.stack([z[..., 0] * np.cos(z[..., 1]), z[..., 0] * np.sin(z[..., 1])], axis=-1)


def world_xy(pose: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Landmark world position from vehicle pose [x, y, φ] and z = [range, bearing]
    (thesis eq. 5.40: g = [x + r cos(θ + φ), y + r sin(θ + φ)])."""
    pose = np.asarray(pose, dtype=np.float64)
    z = np.asarray(z, dtype=np.float64)
    a = z[..., 1] + pose[..., 2]
    return np.stack(
        [pose[..., 0] + z[..., 0] * np.cos(a), pose[..., 1] + z[..., 0] * np.sin(a)], axis=-1
    )


def pixel_from_body(geometry: Geometry, xy: np.ndarray, *, ref_row: float = 0.0) -> np.ndarray:
    """Inverse model (for tests and simulation): body-frame seabed points (N, 2) [x, y] →
    continuous pixel (row, col) (N, 2) in the geometry's image layout. Side-scan points must
    have |y| > 0 (y > 0 port); the along-track position maps to row = ref_row + x/Δa."""
    p = np.atleast_2d(np.asarray(xy, dtype=np.float64))
    x, y = p[:, 0], p[:, 1]
    if isinstance(geometry, SideScanGeometry):
        g = geometry
        ground = np.abs(y) - g.transducer_y
        if np.any(ground < 0):
            raise ValueError(
                f"|y| must exceed transducer_y {g.transducer_y} m for a side-scan point"
            )
        slant = np.sqrt(ground**2 + g.altitude**2)
        u = (slant - g.slant_range_min) / g.bin_width - 0.5
        s = g.samples_per_side
        col = np.where(y > 0, (s - 1) - u, s + u)
        row = ref_row + x / g.along_track_spacing
        return np.stack([row, col], axis=1)
    rho = np.hypot(x, y)
    theta = np.arctan2(y, x)
    alt = geometry.altitude or 0.0
    slant = np.sqrt(rho**2 + alt**2)
    if isinstance(geometry, FLSGeometry):
        g = geometry
        if g.layout == "polar":
            i = (slant - g.range_min) / g.bin_width - 0.5
            j = (np.radians(g.horizontal_fov_deg) / 2.0 - theta) / g.beam_spacing - 0.5
            return np.stack([i, j], axis=1)
        sx, sy = slant * np.cos(theta), slant * np.sin(theta)
        ps = g.pixel_size
        return np.stack([(g.range_max - sx) / ps - 0.5, (g.y_max - sy) / ps - 0.5], axis=1)
    if isinstance(geometry, MSISGeometry):
        g = geometry
        k = (np.degrees(theta) - (g.sector_center_deg - g.sector_deg / 2.0)) / g.step_deg
        k = np.mod(k + 0.5, 360.0 / g.step_deg) - 0.5 if g.sector_deg >= 360 else k
        i = (slant - g.range_min) / g.bin_width - 0.5
        return np.stack([k, i], axis=1)
    raise ValueError(f"unknown geometry type {type(geometry).__name__}")


def sss_geometry_from_waterfall(
    waterfall,
    ping: int,
    *,
    altitude: float | str = "first_return",
    along_track_spacing: float | None = None,
    along_track_beamwidth_deg: float = 0.0,
) -> SideScanGeometry:
    """Side-scan geometry of one ping of a :class:`slam.io.waterfall.Waterfall`.

    altitude : metres, ``"nav"`` (the file's ``altitude_m`` navigation field), or
        ``"first_return"`` (default): the slant range of the first seabed return, the
        mean of both sides (:func:`slam.frontend.normalization.first_return_index`), i.e.
        the altitude the sonar itself measured over a flat seabed.
    along_track_spacing : m per ping; default: navigation speed (knots) × median ping
        interval. Raises ValueError when neither is available.
    """
    from slam.frontend.normalization import first_return_index

    p = waterfall.n_pings
    if not 0 <= ping < p:
        raise ValueError(f"ping {ping} out of range [0, {p})")
    s = waterfall.samples_per_side
    r_max = float(waterfall.slant_range_m[ping])
    if not np.isfinite(r_max) or r_max <= 0:
        raise ValueError(f"waterfall has no slant range for ping {ping} (got {r_max})")
    if altitude == "nav":
        if "altitude_m" not in waterfall.nav:
            raise ValueError("altitude='nav' but the waterfall has no altitude_m navigation")
        alt = float(waterfall.nav["altitude_m"][ping])
    elif altitude == "first_return":
        idx = [
            first_return_index(waterfall.port[ping]),
            first_return_index(waterfall.starboard[ping]),
        ]
        alt = (float(np.mean(idx)) + 0.5) * r_max / s
    else:
        alt = float(altitude)
    if along_track_spacing is None:
        dt = np.diff(waterfall.time_s)
        if "speed_knots" not in waterfall.nav or dt.size == 0 or not np.all(np.isfinite(dt)):
            raise ValueError(
                "along_track_spacing not given and the waterfall has no speed/time to derive it"
            )
        along_track_spacing = (
            float(waterfall.nav["speed_knots"][ping]) * 0.514444 * float(np.median(dt))
        )
    return SideScanGeometry(
        slant_range_max=r_max,
        samples_per_side=s,
        altitude=alt,
        along_track_spacing=float(along_track_spacing),
        along_track_beamwidth_deg=along_track_beamwidth_deg,
    )

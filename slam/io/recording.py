"""The result of every side-scan reader: :class:`SidescanRecording` (waterfall + per-ping
:class:`PingNav`), and conversions between it and the ``Waterfall.nav`` dict."""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from slam.io.waterfall import Waterfall


@dataclass(frozen=True)
class PingNav:
    """Per-ping navigation, every field a (P,) float64 array, nan where unknown.

    lon_deg, lat_deg : WGS84 position of the sonar (or its towing ship when that is all the
        file has), degrees.
    easting_m, northing_m : projected position in the file's own metric frame, m (nan when
        the file gives geographic positions only).
    heading_deg : compass heading, degrees clockwise from north.
    altitude_m : height of the transducer above the seabed, m (for a hull-mounted
        recreational unit: the unit's own bottom depth below the transducer).
    depth_m : depth of the transducer below the surface, m.
    speed_m_s : speed over ground, m/s.
    """

    lon_deg: np.ndarray
    lat_deg: np.ndarray
    easting_m: np.ndarray
    northing_m: np.ndarray
    heading_deg: np.ndarray
    altitude_m: np.ndarray
    depth_m: np.ndarray
    speed_m_s: np.ndarray

    def __post_init__(self) -> None:
        n = None
        for f in fields(self):
            a = np.asarray(getattr(self, f.name), dtype=np.float64).reshape(-1)
            if n is None:
                n = a.size
            elif a.size != n:
                raise ValueError(f"PingNav.{f.name} has {a.size} values, expected {n}")
            a = a.copy()
            a.setflags(write=False)
            object.__setattr__(self, f.name, a)

    @classmethod
    def unknown(cls, n: int) -> PingNav:
        """All-nan navigation for ``n`` pings."""
        return cls(*([np.full(n, np.nan)] * len(fields(cls))))

    @property
    def has_position(self) -> np.ndarray:
        """(P,) bool: the ping carries a finite, non-zero lon/lat."""
        lon, lat = self.lon_deg, self.lat_deg
        return np.isfinite(lon) & np.isfinite(lat) & ~((lon == 0) & (lat == 0))

    def subset(self, rows: np.ndarray) -> PingNav:
        """The navigation of the selected rows (index or boolean array)."""
        return PingNav(*(getattr(self, f.name)[rows] for f in fields(self)))


@dataclass(frozen=True)
class SidescanRecording:
    """A side-scan recording read from a file.

    waterfall : intensity (P, 2·S), time, slant range and frequency per ping
        (:class:`~slam.io.waterfall.Waterfall`); its ``nav`` dict holds the same navigation
        under the keys :mod:`slam.sidescan_slam` reads (``x`` = lon, ``y`` = lat,
        ``heading_deg``, ``altitude_m``, ``xtf_nav_units`` = 3 for degrees).
    nav : per-ping navigation arrays (:class:`PingNav`), same P.
    format : ``"xtf"``, ``"jsf"``, ``"humminbird"``, ``"lowrance"`` or ``"garmin"``.
    """

    waterfall: Waterfall
    nav: PingNav
    format: str

    def __post_init__(self) -> None:
        if self.nav.lon_deg.size != self.waterfall.n_pings:
            raise ValueError(
                f"SidescanRecording: nav has {self.nav.lon_deg.size} pings, waterfall "
                f"{self.waterfall.n_pings}"
            )

    @property
    def n_pings(self) -> int:
        return self.waterfall.n_pings

    @property
    def time_s(self) -> np.ndarray:
        return self.waterfall.time_s

    @property
    def range_m(self) -> np.ndarray:
        """(P,) maximum slant range of each ping, m."""
        return self.waterfall.slant_range_m

    @property
    def frequency_hz(self) -> np.ndarray:
        return self.waterfall.frequency_hz


def nav_dict_from_pingnav(nav: PingNav) -> dict:
    """The ``Waterfall.nav`` dict (keys of :mod:`slam.io.xtf`) for a :class:`PingNav`:
    positions as lon/lat degrees flagged ``xtf_nav_units`` = 3; only fields with a finite
    non-zero value are kept."""
    out = {}
    pairs = {
        "x": nav.lon_deg,
        "y": nav.lat_deg,
        "heading_deg": nav.heading_deg,
        "altitude_m": nav.altitude_m,
        "depth_m": nav.depth_m,
        "speed_m_s": nav.speed_m_s,
    }
    for key, v in pairs.items():
        if np.any(np.isfinite(v) & (v != 0)):
            out[key] = np.where(np.isfinite(v), v, 0.0)
    if "x" in out or "y" in out:
        out["xtf_nav_units"] = np.full(nav.lon_deg.size, 3.0)
    return out


def pingnav_from_xtf(wf: Waterfall) -> PingNav:
    """:class:`PingNav` from the ``nav`` dict :func:`slam.io.xtf.read_xtf` fills: positions
    are lon/lat when the header's NavUnits is 3, projected metres otherwise; zeros (no fix)
    become nan."""
    p = wf.n_pings
    nav = wf.nav

    def get(key: str) -> np.ndarray:
        v = np.asarray(nav.get(key, np.full(p, np.nan)), dtype=np.float64)
        return np.where(v == 0.0, np.nan, v)

    x, y = get("x"), get("y")
    degrees = "xtf_nav_units" in nav and float(np.asarray(nav["xtf_nav_units"])[0]) == 3.0
    nan = np.full(p, np.nan)
    speed_kn = get("speed_knots")
    return PingNav(
        lon_deg=x if degrees else nan,
        lat_deg=y if degrees else nan,
        easting_m=nan if degrees else x,
        northing_m=nan if degrees else y,
        heading_deg=get("heading_deg"),
        altitude_m=get("altitude_m"),
        depth_m=get("depth_m"),
        speed_m_s=speed_kn * 0.514444,
    )

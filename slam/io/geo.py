"""Georeferenced outputs a GIS opens in place: mosaic GeoTIFF and GeoJSON (WGS84).

* :func:`mosaic_from_recording` — bottom track → slant-range correction → mosaic in the
  local UTM zone of the recording's first fix (EPSG 326zz north / 327zz south), or in the
  file's own projected metres (no CRS) when it has no lon/lat.
* :func:`write_geotiff` — one float32 band, nodata = nan, north-up affine transform,
  deflate-compressed (``rasterio``).
* :func:`landmarks_geojson` / :func:`detections_geojson` / :func:`track_geojson` —
  RFC 7946 FeatureCollections in WGS84 lon/lat; a landmark is a Point plus its covariance
  ellipse as a Polygon (``ELLIPSE_K`` standard deviations: the 95 % region of a 2-D
  Gaussian, k = √χ²₂(0.95) = 2.4477).

Local SLAM frames (metres east/north of an origin fix, as
:func:`slam.sidescan_slam.local_poses_from_nav` builds them) are converted back with the
same equirectangular projection: :func:`lonlat_from_local`.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import rasterio
from pyproj import Transformer
from rasterio.transform import from_origin

from slam.frontend.bottom_track import BottomTrack, fill_track, track_bottom
from slam.frontend.mosaic import Mosaic, grid_mosaic, ping_positions_smoothed, slant_range_correct
from slam.io.recording import SidescanRecording

#: Radius of the equirectangular local projection, m (IUGG mean radius; the value
#: slam.sidescan_slam uses for its local frame).
EARTH_RADIUS_M = 6_371_008.8
#: Covariance ellipse scale: the 95 % region of a 2-D Gaussian, √χ²₂(0.95).
ELLIPSE_K = math.sqrt(-2.0 * math.log(0.05))


def utm_epsg(lon_deg: float, lat_deg: float) -> int:
    """EPSG code of the WGS84 UTM zone holding (lon, lat)."""
    if not (-180 <= lon_deg <= 180 and -90 <= lat_deg <= 90):
        raise ValueError(f"lon/lat out of range: ({lon_deg}, {lat_deg})")
    zone = int((lon_deg + 180) // 6) % 60 + 1
    return (32600 if lat_deg >= 0 else 32700) + zone


def project_lonlat(lon: np.ndarray, lat: np.ndarray, epsg: int):
    """(east, north) in EPSG ``epsg`` of WGS84 lon/lat arrays (pyproj, always x = lon)."""
    tr = Transformer.from_crs("EPSG:4326", f"EPSG:{epsg}", always_xy=True)
    e, n = tr.transform(np.asarray(lon, dtype=np.float64), np.asarray(lat, dtype=np.float64))
    return np.asarray(e), np.asarray(n)


def lonlat_from_local(east, north, origin_lonlat: tuple[float, float]):
    """Inverse of the equirectangular local frame about ``origin_lonlat`` (deg)."""
    lon0, lat0 = origin_lonlat
    east, north = np.asarray(east, dtype=np.float64), np.asarray(north, dtype=np.float64)
    lat = lat0 + np.degrees(north / EARTH_RADIUS_M)
    lon = lon0 + np.degrees(east / (EARTH_RADIUS_M * math.cos(math.radians(lat0))))
    return lon, lat


def mosaic_from_recording(
    rec: SidescanRecording, track: BottomTrack, cell_m: float | None = None
) -> Mosaic:
    """Slant-range-corrected mosaic of a recording (see the module docstring).

    The altitude per ping is the bottom track, gaps interpolated (:func:`fill_track`).
    ``cell_m`` defaults to the larger of the median ping spacing along track and the slant
    sample spacing, so most cells hold at least one sample.
    """
    nav = rec.nav
    has_ll = nav.has_position
    if has_ll.sum() >= 2:
        first = int(np.flatnonzero(has_ll)[0])
        epsg = utm_epsg(float(nav.lon_deg[first]), float(nav.lat_deg[first]))
        east, north = project_lonlat(nav.lon_deg, nav.lat_deg, epsg)
        crs = f"EPSG:{epsg}"
    elif np.sum(np.isfinite(nav.easting_m) & np.isfinite(nav.northing_m)) >= 2:
        east, north, crs = nav.easting_m, nav.northing_m, ""
    else:
        raise ValueError(
            f"{rec.waterfall.source}: the recording carries no per-ping position; a "
            "georeferenced mosaic needs lon/lat or projected positions"
        )
    if np.sum(np.isfinite(nav.heading_deg)) < 2:
        raise ValueError(f"{rec.waterfall.source}: the recording carries no heading")
    if crs:
        east, north = np.where(has_ll, east, np.nan), np.where(has_ll, north, np.nan)
    east, north = ping_positions_smoothed(rec.time_s, east, north)
    ground = slant_range_correct(rec.waterfall, fill_track(track))
    if cell_m is None:
        step = np.hypot(np.diff(east), np.diff(north))
        step = step[np.isfinite(step) & (step > 0)]
        along = float(np.median(step)) if step.size else ground.ground_res_m
        cell_m = max(along, ground.ground_res_m)
    return grid_mosaic(ground, east, north, nav.heading_deg, cell_m, crs=crs)


def write_geotiff(path: str | Path, mosaic: Mosaic) -> Path:
    """Write ``mosaic`` as a single-band float32 GeoTIFF (nodata nan)."""
    path = Path(path)
    h, w = mosaic.image.shape
    profile = {
        "driver": "GTiff",
        "height": h,
        "width": w,
        "count": 1,
        "dtype": "float32",
        "nodata": float("nan"),
        "transform": from_origin(mosaic.west_m, mosaic.north_m, mosaic.cell_m, mosaic.cell_m),
        "compress": "deflate",
        "tiled": w >= 256 and h >= 256,
    }
    if mosaic.crs:
        profile["crs"] = mosaic.crs
    with rasterio.open(path, "w", **profile) as dst:
        dst.write(mosaic.image.astype(np.float32), 1)
        dst.set_band_description(1, "side-scan intensity (linear, as recorded)")
    return path


def covariance_ellipse(center: Sequence[float], cov: np.ndarray, k: float = ELLIPSE_K, n: int = 36):
    """(n + 1, 2) closed ring of the k-sigma ellipse of a 2×2 covariance around ``center``."""
    cov = np.asarray(cov, dtype=np.float64).reshape(2, 2)
    vals, vecs = np.linalg.eigh(0.5 * (cov + cov.T))
    if vals.min() < -1e-12 * max(1.0, abs(vals.max())):
        raise ValueError(f"covariance is not positive semi-definite (eigenvalues {vals})")
    a = np.linspace(0.0, 2 * np.pi, n + 1)
    a[-1] = 0.0
    unit = np.stack([np.cos(a), np.sin(a)], axis=1)
    return np.asarray(center, dtype=np.float64) + k * (unit * np.sqrt(np.maximum(vals, 0))) @ vecs.T


def _feature(geometry: dict, properties: dict) -> dict:
    return {"type": "Feature", "geometry": geometry, "properties": properties}


def landmarks_geojson(
    xy_m: np.ndarray,
    cov: np.ndarray,
    to_lonlat: Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]],
    k: float = ELLIPSE_K,
) -> dict:
    """FeatureCollection of landmarks: per landmark a Point (id, sigma_major_m) and its
    covariance ellipse Polygon (``k`` sigma), both in WGS84 via ``to_lonlat(east, north)``."""
    xy_m = np.asarray(xy_m, dtype=np.float64).reshape(-1, 2)
    cov = np.asarray(cov, dtype=np.float64).reshape(-1, 2, 2)
    feats = []
    for i, (c, p) in enumerate(zip(xy_m, cov, strict=True)):
        lon, lat = to_lonlat(c[:1], c[1:])
        sig = float(np.sqrt(max(np.linalg.eigvalsh(p).max(), 0.0)))
        props = {"id": i, "kind": "landmark", "sigma_major_m": sig}
        feats.append(_feature({"type": "Point", "coordinates": [float(lon[0]), float(lat[0])]}, props))
        ring = covariance_ellipse(c, p, k)
        rl, rb = to_lonlat(ring[:, 0], ring[:, 1])
        poly = {"type": "Polygon", "coordinates": [np.stack([rl, rb], 1).tolist()]}
        feats.append(_feature(poly, {**props, "kind": "covariance_ellipse", "k_sigma": k}))
    return {"type": "FeatureCollection", "features": feats}


def detections_geojson(xy_m: np.ndarray, properties: Sequence[dict], to_lonlat) -> dict:
    """FeatureCollection of detection Points (WGS84) with the given properties."""
    xy_m = np.asarray(xy_m, dtype=np.float64).reshape(-1, 2)
    if len(properties) != len(xy_m):
        raise ValueError(f"{len(xy_m)} detections but {len(properties)} property dicts")
    lon, lat = to_lonlat(xy_m[:, 0], xy_m[:, 1])
    feats = [
        _feature({"type": "Point", "coordinates": [float(a), float(b)]}, dict(p))
        for a, b, p in zip(lon, lat, properties, strict=True)
    ]
    return {"type": "FeatureCollection", "features": feats}


def track_geojson(lon_deg: np.ndarray, lat_deg: np.ndarray, properties: dict | None = None) -> dict:
    """FeatureCollection with the vehicle track as one LineString (pings without a fix
    skipped)."""
    lon, lat = np.asarray(lon_deg, dtype=np.float64), np.asarray(lat_deg, dtype=np.float64)
    ok = np.isfinite(lon) & np.isfinite(lat) & ~((lon == 0) & (lat == 0))
    line = {"type": "LineString", "coordinates": np.stack([lon[ok], lat[ok]], 1).tolist()}
    return {"type": "FeatureCollection", "features": [_feature(line, dict(properties or {}))]}


def write_geojson(path: str | Path, collection: dict) -> Path:
    """Write a FeatureCollection (RFC 7946: WGS84 lon/lat, no ``crs`` member)."""
    path = Path(path)
    path.write_text(json.dumps(collection, indent=1))
    return path


def write_slam_geo_outputs(
    out_dir: str | Path,
    rec: SidescanRecording,
    origin_lonlat: tuple[float, float],
    landmarks_xy_m: np.ndarray,
    landmark_cov: np.ndarray,
    detections_xy_m: np.ndarray,
    detection_properties: Sequence[dict],
) -> dict:
    """GIS outputs of a SLAM run on a recording, into ``out_dir``: ``mosaic.tif`` (local
    UTM), ``landmarks.geojson`` (points + 95 % covariance ellipses) and
    ``detections.geojson`` (WGS84). Positions are in the run's local frame (metres
    east/north of ``origin_lonlat``). Returns the written paths by name."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)

    def to_lonlat(e, n):
        return lonlat_from_local(e, n, origin_lonlat)

    track = track_bottom(rec.waterfall)
    paths = {
        "mosaic": write_geotiff(out / "mosaic.tif", mosaic_from_recording(rec, track)),
        "landmarks": write_geojson(
            out / "landmarks.geojson", landmarks_geojson(landmarks_xy_m, landmark_cov, to_lonlat)
        ),
        "detections": write_geojson(
            out / "detections.geojson",
            detections_geojson(detections_xy_m, detection_properties, to_lonlat),
        ),
    }
    return {k: str(v) for k, v in paths.items()}

"""undersea mosaic and normalize over folders: one result per file, a failed file reported
(stderr, batch.json) without losing the others, exit 2 on bad input."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest
import rasterio
from recording_writers import write_xtf

from sim.cli.main import main


def _nav_xtf(path, rng, p=30, s=200):
    port = (50 + rng.integers(0, 5, size=(p, s))).astype(np.uint16)
    stbd = (50 + rng.integers(0, 5, size=(p, s))).astype(np.uint16)
    port[:, -30:] = 2
    stbd[:, :30] = 2
    lat = 48.5 + np.arange(p) * 1e-5
    return write_xtf(path, port, stbd, np.arange(p) * 0.5, slant=20.0,
                     lonlat=(np.full(p, -68.8), lat), heading=np.full(p, 1.0),
                     altitude=np.full(p, 3.0))


def test_mosaic_folder_keeps_good_files_and_reports_bad_ones(tmp_path, rng, capsys):
    src = tmp_path / "in"
    src.mkdir()
    good = _nav_xtf(src / "good.xtf", rng)
    (src / "cut.xtf").write_bytes(good.read_bytes()[: 1024 + 100])
    (src / "junk.sl2").write_bytes(b"not a sonar log" * 40)
    (src / "notes.txt").write_text("ignored: not a recording suffix")
    out = tmp_path / "out"
    assert main(["mosaic", str(src), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "cut.xtf: truncated XTF file" in err and "junk.sl2" in err
    results = json.loads((out / "batch.json").read_text())
    assert [r["ok"] for r in results] == [False, True, False]  # cut, good, junk (sorted)
    assert results[1]["bottom_vs_file_altitude"]["r"] is None  # constant altitude: no r
    with rasterio.open(out / "good.tif") as ds:
        assert ds.crs.to_epsg() == 32619
    track = json.loads((out / "good_track.geojson").read_text())
    assert track["features"][0]["geometry"]["type"] == "LineString"


@pytest.mark.parametrize("content,suffix,message", [
    (b"", ".xtf", "empty file"),
    (b"PK\x03\x04" + bytes(3000), ".xtf", "not an XTF"),
    (b"abc", ".doc", "unsupported side-scan recording suffix"),
])
def test_mosaic_single_bad_file_exit_2(tmp_path, capsys, content, suffix, message):
    bad = tmp_path / f"bad{suffix}"
    bad.write_bytes(content)
    assert main(["mosaic", str(bad), "--out", str(tmp_path / "o")]) == 2
    assert message in capsys.readouterr().err


def test_mosaic_without_navigation_is_a_clear_error(tmp_path, rng, capsys):
    p, s = 10, 64
    px = rng.integers(1, 100, size=(p, s)).astype(np.uint16)
    path = write_xtf(tmp_path / "nonav.xtf", px, px, np.arange(p, dtype=float))
    assert main(["mosaic", str(path), "--out", str(tmp_path / "o")]) == 2
    assert "no per-ping position" in capsys.readouterr().err


def test_normalize_batch_over_a_folder(tmp_path, rng, capsys):
    src = tmp_path / "imgs"
    src.mkdir()
    for k in range(2):
        img = rng.rayleigh(40.0, size=(48, 128)).clip(0, 255).astype(np.uint8)
        cv2.imwrite(str(src / f"w{k}.png"), img)
    (src / "broken.png").write_bytes(b"\x89PNG\r\n\x1a\n garbage")
    out = tmp_path / "out"
    code = main(["normalize", str(src), "--method", "dcp", "--patch", "16", "--out", str(out),
                 "--json"])
    cap = capsys.readouterr()
    assert code == 2
    results = json.loads(cap.out)
    assert [(r["file"].rsplit("/", 1)[-1], r["ok"]) for r in results] == [
        ("broken.png", False), ("w0.png", True), ("w1.png", True)]
    assert "broken.png" in cap.err
    assert cv2.imread(str(out / "w1.png"), cv2.IMREAD_UNCHANGED).shape == (48, 128)


@pytest.mark.shared_data
def test_mosaic_real_humminbird(shared_data, tmp_path, capsys):
    out = tmp_path / "hb"
    assert main(["mosaic", str(shared_data / "humminbird" / "test.DAT"), "--out", str(out),
                 "--json"]) == 0
    res = json.loads(capsys.readouterr().out)[0]
    assert res["format"] == "humminbird" and res["crs"] == "EPSG:32612"
    track = json.loads((out / "test_track.geojson").read_text())
    lon, lat = np.array(track["features"][0]["geometry"]["coordinates"]).T
    with rasterio.open(out / "test.tif") as ds:
        from rasterio.warp import transform

        xs, ys = transform("EPSG:4326", ds.crs, lon.tolist(), lat.tolist())
        b = ds.bounds
        assert b.left <= min(xs) and max(xs) <= b.right
        assert b.bottom <= min(ys) and max(ys) <= b.top
        band = ds.read(1)
    assert 0.15 < np.isfinite(band).mean() < 0.9


@pytest.mark.shared_data
def test_sss_slam_gis_outputs_agree_with_the_mosaic(shared_data, tmp_path):
    """Scotsman XTF: the detections (GeoJSON, WGS84, from the SLAM's local frame) fall on
    the mosaic's swath (GeoTIFF, built from UTM), and a landmark lies within 25 m of the
    source's wreck label (.hits: channel, sample, ping) georeferenced independently here
    from that ping's fix, heading and altitude (flat seabed, starboard = heading + 90°)."""
    from pyproj import Transformer

    xtf = shared_data / "xtf" / "scotsman-iver2.xtf"
    out = tmp_path / "sss"
    assert main(["sss-slam", str(xtf), "--out", str(out)]) == 0
    lm = json.loads((out / "landmarks.geojson").read_text())
    pts = [f["geometry"]["coordinates"] for f in lm["features"]
           if f["properties"]["kind"] == "landmark"]
    ellipses = [f for f in lm["features"] if f["properties"]["kind"] == "covariance_ellipse"]
    assert pts and len(ellipses) == len(pts)
    det = json.loads((out / "detections.geojson").read_text())["features"]
    with rasterio.open(out / "mosaic.tif") as ds:
        band = ds.read(1)
        tr = Transformer.from_crs("EPSG:4326", ds.crs, always_xy=True)
        on_swath = [np.isfinite(band[ds.index(*tr.transform(*f["geometry"]["coordinates"]))])
                    for f in det]
    assert det and np.mean(on_swath) >= 0.8
    from slam.io.sidescan import read_sidescan

    rec = read_sidescan(xtf)
    _, sample, ping = map(int, (xtf.parent / (xtf.name + ".hits")).read_text().split())
    slant = (sample + 0.5) * rec.waterfall.sample_spacing_m()[ping]
    ground = np.sqrt(max(slant**2 - rec.nav.altitude_m[ping] ** 2, 0.0))
    e, n = tr.transform(rec.nav.lon_deg[ping], rec.nav.lat_deg[ping])
    th = np.radians(rec.nav.heading_deg[ping])
    label = np.array([e + ground * np.cos(th), n - ground * np.sin(th)])
    dist = [np.hypot(*(np.array(tr.transform(*p)) - label)) for p in pts]
    assert min(dist) < 25.0

"""``undersea mosaic FILE|DIR ... --out DIR``: bottom-track a side-scan recording, correct
slant range, and write a georeferenced mosaic GeoTIFF (local UTM) with the vehicle track
and the bottom track, one set of outputs per recording.

Per recording ``NAME`` in ``--out``: ``NAME.tif`` (float32 mosaic, nodata nan, opens in
QGIS), ``NAME_track.geojson`` (WGS84 LineString), ``NAME_bottom.csv`` (ping, time, bottom
track altitude, file altitude field), and with ``--figures`` ``NAME_mosaic.png`` and
``NAME_bottom.png``. ``batch.json`` lists one result per file.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
from pathlib import Path

import numpy as np

from sim.cli.batch import expand_inputs, run_batch


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "files", nargs="+",
        help="recordings (.xtf .jsf .DAT/.SON .sl2 .sl3 .rsd) or folders of them",
    )
    parser.add_argument("--out", required=True, help="output directory")
    parser.add_argument(
        "--cell", type=float, default=None,
        help="mosaic cell size, m (default: the larger of ping spacing and sample spacing)",
    )
    parser.add_argument("--figures", action="store_true", help="also write PNG figures")
    parser.add_argument("--json", action="store_true", help="print the results as JSON")


def mosaic_one(path: Path, out: Path, cell_m: float | None, figures: bool) -> dict:
    """All outputs of one recording; returns its result summary."""
    from slam.frontend.bottom_track import track_bottom
    from slam.io.geo import mosaic_from_recording, track_geojson, write_geojson, write_geotiff
    from slam.io.sidescan import read_sidescan

    rec = read_sidescan(path)
    track = track_bottom(rec.waterfall)
    mosaic = mosaic_from_recording(rec, track, cell_m)
    stem = path.stem
    tif = write_geotiff(out / f"{stem}.tif", mosaic)
    geo = write_geojson(
        out / f"{stem}_track.geojson",
        track_geojson(rec.nav.lon_deg, rec.nav.lat_deg, {"file": str(path), "format": rec.format}),
    )
    csv = out / f"{stem}_bottom.csv"
    table = np.column_stack(
        [np.arange(rec.n_pings), rec.time_s, track.altitude_m, rec.nav.altitude_m]
    )
    np.savetxt(csv, table, delimiter=",", fmt="%.4f",
               header="ping,time_s,bottom_track_altitude_m,file_altitude_m", comments="")
    ref = rec.nav.altitude_m
    both = np.isfinite(ref) & track.found
    res = {
        "format": rec.format,
        "pings": rec.n_pings,
        "bottom_found_fraction": float(track.found.mean()),
        "mosaic": str(tif),
        "mosaic_shape": list(mosaic.image.shape),
        "cell_m": mosaic.cell_m,
        "crs": mosaic.crs,
        "track": str(geo),
        "bottom_csv": str(csv),
    }
    if both.sum() >= 3:
        a, b = track.altitude_m[both], ref[both]
        d = a - b
        varies = np.std(a) > 0 and np.std(b) > 0  # r is undefined for a constant series
        res["bottom_vs_file_altitude"] = {
            "r": float(np.corrcoef(a, b)[0, 1]) if varies else None,
            "rmse_m": float(np.sqrt(np.mean(d**2))),
            "bias_m": float(np.mean(d)),
            "pings": int(both.sum()),
        }
    if figures:
        from sim.viz.sidescan_figures import plot_bottom_track, plot_mosaic

        res["figures"] = [
            str(plot_mosaic(mosaic, out / f"{stem}_mosaic.png", title=f"{path.name}: mosaic")),
            str(plot_bottom_track(rec, track, out / f"{stem}_bottom.png")),
        ]
    return res


def run(args: argparse.Namespace) -> int:
    from slam.io.sidescan import SUFFIX_FORMATS

    out = Path(args.out)
    try:
        if args.cell is not None and not (np.isfinite(args.cell) and args.cell > 0):
            raise ValueError(f"--cell must be > 0 m, got {args.cell}")
        # folders: Humminbird recordings are found by their .DAT, not their .SON files
        files = expand_inputs(args.files, [s for s in SUFFIX_FORMATS if s != ".son"])
        created = not out.exists()
        out.mkdir(parents=True, exist_ok=True)
    except (ValueError, OSError) as exc:
        print(f"undersea mosaic: {exc}", file=sys.stderr)
        return 2
    results, code = run_batch(
        files, lambda f: mosaic_one(f, out, args.cell, args.figures), command="mosaic"
    )
    if any(r["ok"] for r in results):
        (out / "batch.json").write_text(json.dumps(results, indent=1))
    elif created:  # nothing made: leave nothing behind
        shutil.rmtree(out, ignore_errors=True)
    if args.json:
        print(json.dumps(results, indent=1))
    else:
        for r in results:
            if not r["ok"]:
                print(f"{r['file']}: FAILED ({r['error']})")
                continue
            line = (f"{r['file']}: {r['pings']} pings ({r['format']}), mosaic "
                    f"{r['mosaic_shape'][1]}x{r['mosaic_shape'][0]} at {r['cell_m']:.3f} m "
                    f"{r['crs'] or '(no CRS)'} -> {r['mosaic']}")
            print(line)
            if "bottom_vs_file_altitude" in r:
                b = r["bottom_vs_file_altitude"]
                r_txt = "n/a (constant)" if b["r"] is None else f"{b['r']:.3f}"
                print(f"  bottom track vs file altitude: r = {r_txt}, RMSE {b['rmse_m']:.2f} m, "
                      f"bias {b['bias_m']:+.2f} m over {b['pings']} pings")
    return code

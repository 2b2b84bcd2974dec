"""``undersea normalize FILE|DIR ...``: MIRA / DCP intensity normalization of side-scan
waterfalls (recordings read by :func:`slam.io.sidescan.read_sidescan`, or image files)
with SIQEM before and after (thesis Ch. 4.1).

One file: ``--out``/``--compare`` are PNG paths, as before. Several files or a folder:
a batch with a progress bar; ``--out``/``--compare`` are directories receiving
``NAME.png`` / ``NAME_compare.png``, a failed file is reported on stderr and the others
still run (exit 2 when any failed); ``--json`` prints one list of per-file results."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from sim.cli.batch import expand_inputs, run_batch
from sim.cli.common import print_json, writable_file


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "files", nargs="+",
        help="recordings (.xtf .jsf .DAT .sl2 .sl3 .rsd), PNG/JPG/TIFF waterfalls (port left, "
        "starboard right), or folders of them",
    )
    parser.add_argument("--method", choices=("mira", "dcp", "none"), default="mira")
    parser.add_argument(
        "--ping", type=int, default=None, help="MIRA: ping row to fit (default: middle)"
    )
    parser.add_argument(
        "--block", type=int, default=None, help="MIRA: fit one model per block of N pings"
    )
    parser.add_argument(
        "--average", type=int, default=1, help="MIRA: pings averaged into the fitted profile"
    )
    parser.add_argument("--patch", type=int, default=32, help="SIQEM patch size, px (default 32)")
    parser.add_argument(
        "--out", default=None,
        help="write the normalized waterfall as an 8-bit PNG (a directory for a batch)",
    )
    parser.add_argument(
        "--compare", default=None, help="write a before/after figure PNG (a directory for a batch)"
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object")


def load_waterfall(path: str):
    """Recording → Waterfall (read_sidescan); image → Waterfall (width must be even: left
    half port)."""
    from slam.io.images import read_image
    from slam.io.sidescan import SUFFIX_FORMATS, read_sidescan
    from slam.io.waterfall import waterfall_from_image

    p = Path(path)
    if p.suffix.lower() in SUFFIX_FORMATS:
        return read_sidescan(p).waterfall
    img = read_image(p).image
    return waterfall_from_image(img, source=str(p))


def display_uint8(image):
    """Display mapping used for every PNG here: 1st–99th percentile stretch to 0..255."""
    from slam.frontend.matching import to_uint8

    return to_uint8(image, low=1.0, high=99.0)


def normalize_one(path: str, args: argparse.Namespace, out_png, compare_png) -> dict:
    """Normalize one file, write its PNGs; returns its report (ValueError on bad input)."""
    from slam.frontend.bottom_track import seabed_region
    from slam.frontend.normalization import dcp_normalize, mira_normalize
    from slam.frontend.quality import siqem

    wf = load_waterfall(path)
    t0 = time.perf_counter()
    fits = None
    if args.method == "mira":
        res = mira_normalize(wf, ping=args.ping, block=args.block, average=args.average)
        out = res.normalized
        fits = {
            "port": [f.__dict__ for f in res.port],
            "starboard": [f.__dict__ for f in res.starboard],
        }
    elif args.method == "dcp":
        out = dcp_normalize(wf.intensity)
    else:
        out = wf.intensity
    elapsed = time.perf_counter() - t0
    patch = (args.patch, args.patch)
    mask = seabed_region(wf)  # bottom track on recordings, threshold rule on images
    report = {
        "file": str(path),
        "method": args.method,
        "shape": list(wf.intensity.shape),
        "siqem_before": siqem(wf.intensity, patch=patch),
        "siqem_after": siqem(out, patch=patch),
        "siqem_seabed_before": siqem(wf.intensity, patch=patch, mask=mask),
        "siqem_seabed_after": siqem(out, patch=patch, mask=mask),
        "patch_px": args.patch,
        "time_s": elapsed,
        "fits": fits,
    }
    if out_png:
        import cv2

        if not cv2.imwrite(str(out_png), display_uint8(out)):
            raise ValueError(f"could not write {out_png}")
        report["out"] = str(out_png)
    if compare_png:
        _write_compare(wf.intensity, out, report, args.method, compare_png)
        report["compare"] = str(compare_png)
    return report


def _write_compare(raw, out, report: dict, method: str, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(2, 1, figsize=(10, 2 * 10 * out.shape[0] / out.shape[1] + 1))
    for a, img, title in (
        (ax[0], raw, f"raw (SIQEM {report['siqem_before']:.3f})"),
        (ax[1], out, f"{method} (SIQEM {report['siqem_after']:.3f})"),
    ):
        a.imshow(display_uint8(img), cmap="gray", aspect="auto")
        a.set_title(title)
        a.set_ylabel("ping")
    ax[1].set_xlabel("sample (port far range | nadir | starboard far range)")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def _print_report(report: dict, args: argparse.Namespace) -> None:
    print(
        f"{report['file']}: {report['shape'][0]} pings x {report['shape'][1]} samples, "
        f"method {args.method}"
    )
    print(
        f"SIQEM (patch {args.patch} px) before {report['siqem_before']:.4f} "
        f"after {report['siqem_after']:.4f}"
    )
    print(
        f"SIQEM seabed only   before {report['siqem_seabed_before']:.4f} "
        f"after {report['siqem_seabed_after']:.4f}"
    )
    fits = report["fits"]
    if fits:
        for side in ("port", "starboard"):
            f = fits[side][0]
            print(
                f"  {side}: a={f['a']:.4g} b={f['b']:.4g} c={f['c']:.4g} d={f['d']:.4g} "
                f"(ping {f['ping']}, fit from sample {f['start']}; {len(fits[side])} model(s))"
            )
    print(f"time {report['time_s'] * 1e3:.1f} ms")


def run(args: argparse.Namespace) -> int:
    from slam.io.images import SUPPORTED_SUFFIXES
    from slam.io.sidescan import SUFFIX_FORMATS

    single = len(args.files) == 1 and not Path(args.files[0]).is_dir()
    if single:
        writable_file(args.out, "--out")  # CliError: message on stderr, exit 2
        writable_file(args.compare, "--compare")
        try:
            report = normalize_one(args.files[0], args, args.out, args.compare)
        except ValueError as exc:
            print(f"undersea normalize: {exc}", file=sys.stderr)
            return 2
        if args.json:
            print_json(report)
        else:
            _print_report(report, args)
        return 0
    try:
        suffixes = [*SUPPORTED_SUFFIXES, *(s for s in SUFFIX_FORMATS if s != ".son")]
        files = expand_inputs(args.files, suffixes)
        dirs = [Path(d) for d in (args.out, args.compare) if d]
        for d in dirs:
            d.mkdir(parents=True, exist_ok=True)
    except (ValueError, OSError) as exc:
        print(f"undersea normalize: {exc}", file=sys.stderr)
        return 2

    def one(f: Path) -> dict:
        out_png = Path(args.out) / f"{f.stem}.png" if args.out else None
        cmp_png = Path(args.compare) / f"{f.stem}_compare.png" if args.compare else None
        return normalize_one(str(f), args, out_png, cmp_png)

    results, code = run_batch(files, one, command="normalize")
    if args.json:
        print_json(results)
    else:
        for r in results:
            if r["ok"]:
                _print_report(r, args)
            else:
                print(f"{r['file']}: FAILED ({r['error']})")
    return code

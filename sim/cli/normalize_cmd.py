"""``undersea normalize FILE``: MIRA / DCP intensity normalization of a side-scan waterfall
(XTF recording or image file) with SIQEM before and after (thesis Ch. 4.1)."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from sim.cli.common import CliError, print_json, writable_file

HELP = "normalize a side-scan waterfall (.xtf or image) with MIRA or DCP; print SIQEM before/after"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "file", help="XTF recording or PNG/JPG/TIFF waterfall (port left, starboard right)"
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
        "--out", default=None, help="write the normalized waterfall as an 8-bit PNG"
    )
    parser.add_argument("--compare", default=None, help="write a before/after figure PNG")
    parser.add_argument("--json", action="store_true", help="print one JSON object")


def load_waterfall(path: str):
    """XTF → Waterfall; image → Waterfall (width must be even: left half port)."""
    from slam.io.images import read_image
    from slam.io.waterfall import waterfall_from_image
    from slam.io.xtf import read_xtf

    p = Path(path)
    if p.suffix.lower() == ".xtf":
        return read_xtf(p)
    img = read_image(p).image
    return waterfall_from_image(img, source=str(p))


def display_uint8(image):
    """Display mapping used for every PNG here: 1st–99th percentile stretch to 0..255."""
    from slam.frontend.matching import to_uint8

    return to_uint8(image, low=1.0, high=99.0)


def run(args: argparse.Namespace) -> int:
    from slam.frontend.normalization import dcp_normalize, mira_normalize, seabed_mask
    from slam.frontend.quality import siqem

    writable_file(args.out, "--out")
    writable_file(args.compare, "--compare")
    try:
        wf = load_waterfall(args.file)
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
        mask = seabed_mask(wf)
        report = {
            "file": str(args.file),
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
    except ValueError as exc:
        print(f"undersea normalize: {exc}", file=sys.stderr)
        return 2
    if args.out:
        import cv2

        if not cv2.imwrite(args.out, display_uint8(out)):
            raise CliError(f"--out {args.out!r}: OpenCV could not write it; allowed: a .png path")
        report["out"] = args.out
    if args.compare:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(2, 1, figsize=(10, 2 * 10 * out.shape[0] / out.shape[1] + 1))
        for a, img, title in (
            (ax[0], wf.intensity, f"raw (SIQEM {report['siqem_before']:.3f})"),
            (ax[1], out, f"{args.method} (SIQEM {report['siqem_after']:.3f})"),
        ):
            a.imshow(display_uint8(img), cmap="gray", aspect="auto")
            a.set_title(title)
            a.set_ylabel("ping")
        ax[1].set_xlabel("sample (port far range | nadir | starboard far range)")
        fig.tight_layout()
        fig.savefig(args.compare, dpi=100)
        plt.close(fig)
        report["compare"] = args.compare
    if args.json:
        print_json(report)
    else:
        print(
            f"{report['file']}: {report['shape'][0]} pings x {report['shape'][1]} samples, method {args.method}"
        )
        print(
            f"SIQEM (patch {args.patch} px) before {report['siqem_before']:.4f} after {report['siqem_after']:.4f}"
        )
        print(
            f"SIQEM seabed only   before {report['siqem_seabed_before']:.4f} "
            f"after {report['siqem_seabed_after']:.4f}"
        )
        if fits:
            for side in ("port", "starboard"):
                f = fits[side][0]
                print(
                    f"  {side}: a={f['a']:.4g} b={f['b']:.4g} c={f['c']:.4g} d={f['d']:.4g} "
                    f"(ping {f['ping']}, fit from sample {f['start']}; {len(fits[side])} model(s))"
                )
        print(f"time {elapsed * 1e3:.1f} ms")
    return 0

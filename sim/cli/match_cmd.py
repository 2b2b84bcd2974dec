"""``undersea match A B``: keypoint matching of two sonar images (thesis Ch. 4.2)."""

from __future__ import annotations

import argparse
import sys

from sim.cli.common import CliError, finite_float, print_json, writable_file
from slam.frontend.matching import DETECTORS

DETECTOR_HELP = (
    "harris: Harris corners with SIFT descriptors oriented by the intensity centroid "
    "(rotation-, not scale-invariant); brisk: BRISK binary descriptors; sift; orb; asift: "
    "affine SIFT. SURF is not offered: pip's OpenCV does not build its patented code"
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("a", help="first image (PNG/JPG/TIFF)")
    parser.add_argument("b", help="second image")
    parser.add_argument(
        "--detector",
        choices=DETECTORS,
        default="sift",
        help=DETECTOR_HELP,
    )
    parser.add_argument(
        "--ratio", type=finite_float, default=0.8, help="alpha of eqs. 4.17-4.18, in (0, 1]"
    )
    parser.add_argument("--model", choices=("similarity", "homography"), default="similarity")
    parser.add_argument("--ransac-threshold", type=finite_float, default=3.0, help="px")
    parser.add_argument("--plot", default=None, help="write a PNG of the inlier matches")
    parser.add_argument("--json", action="store_true", help="print one JSON object")


def run(args: argparse.Namespace) -> int:
    from slam.frontend.matching import match_images
    from slam.io.images import read_image

    writable_file(args.plot, "--plot")
    try:
        a = read_image(args.a).image
        b = read_image(args.b).image
        res = match_images(
            a,
            b,
            detector=args.detector,
            ratio=args.ratio,
            model=args.model,
            ransac_threshold=args.ransac_threshold,
        )
    except ValueError as exc:
        print(f"undersea match: {exc}", file=sys.stderr)
        return 2
    out = res.summary()
    if args.plot:
        import cv2

        from slam.frontend.matching import detect, to_uint8

        ka, kb = detect(a, args.detector), detect(b, args.detector)
        kpa = [cv2.KeyPoint(float(x), float(y), 5) for x, y in ka.points]
        kpb = [cv2.KeyPoint(float(x), float(y), 5) for x, y in kb.points]
        good = [
            cv2.DMatch(int(i), int(j), 0.0)
            for (i, j), ok in zip(res.pairs, res.inliers, strict=True)
            if ok
        ]
        vis = cv2.drawMatches(
            to_uint8(a),
            kpa,
            to_uint8(b),
            kpb,
            good,
            None,
            matchColor=(0, 255, 0),
            flags=cv2.DrawMatchesFlags_NOT_DRAW_SINGLE_POINTS,
        )
        if not cv2.imwrite(args.plot, vis):
            raise CliError(f"--plot {args.plot!r}: OpenCV could not write it; allowed: a .png path")
        out["plot"] = args.plot
    if args.json:
        print_json(out)
    else:
        print(
            f"{args.detector}: {out['keypoints_a']} / {out['keypoints_b']} keypoints, "
            f"{out['candidates']} bidirectional pairs (alpha {args.ratio}), {out['inliers']} RANSAC inliers"
        )
        print(f"matched: {out['matched']} (>= 3 inliers)")
        if res.transform is not None:
            print(f"rotation {res.rotation_deg:.2f} deg ccw, scale {res.scale:.4f}")
        print(f"time {res.time_s * 1e3:.1f} ms")
    return 0

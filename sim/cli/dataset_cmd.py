"""``undersea dataset SCENARIO --frames N --out DIR [--seed S] [--workers K] [--ray [ADDRESS]]
[--kind sss|fls|both] [--tile-pings P]``: labelled sonar frames in COCO format."""

from __future__ import annotations

import argparse
import sys

from sim.cli.common import finite_float, print_json


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "scenario", help="built-in scenario name (see `undersea scenarios`) or a .toml file"
    )
    parser.add_argument("--frames", type=int, required=True, help="number of frames N (>= 1)")
    parser.add_argument(
        "--out", required=True, help="output directory (resumes if it holds the same dataset)"
    )
    parser.add_argument(
        "--force",
        action="store_true",
        help="--out holds a dataset of another plan: delete it and start over",
    )
    parser.add_argument("--seed", type=int, default=0, help="dataset seed (default 0)")
    parser.add_argument(
        "--workers", type=int, default=1, help="parallel workers (default 1: serial)"
    )
    parser.add_argument(
        "--ray",
        dest="ray_address",
        nargs="?",
        const="local",
        default=None,
        metavar="ADDRESS",
        help="run on Ray: a cluster address, or no value for a local Ray",
    )
    parser.add_argument("--kind", default="both", help="sss | fls | both (default both)")
    parser.add_argument(
        "--tile-pings", type=int, default=64, help="pings per side-scan tile (default 64)"
    )
    parser.add_argument(
        "--fls-view", default="polar", help="FLS image: polar | fan | both (default polar)"
    )
    parser.add_argument(
        "--fls-interval",
        type=finite_float,
        default=1.0,
        help="simulated seconds between exported FLS frames (default 1.0)",
    )
    parser.add_argument(
        "--shard-frames",
        type=int,
        default=32,
        help="frames per shard, the unit of parallel work and resume (default 32)",
    )
    parser.add_argument(
        "--segmentation", default="rle", help="rle (pixel-exact) | polygon (default rle)"
    )
    parser.add_argument(
        "--npy", action="store_true", help="also write float32 linear intensity .npy files"
    )
    parser.add_argument(
        "--min-objects",
        type=int,
        default=0,
        help="keep only frames showing at least this many objects (default 0: all frames)",
    )
    parser.add_argument(
        "--no-spread",
        action="store_true",
        help="start every shard at t = 0 instead of spreading shards over the mission",
    )
    parser.add_argument(
        "--set",
        dest="overrides",
        action="append",
        metavar="KEY=VALUE",
        help="scenario override (repeatable), e.g. vehicles[0].sonars[0].overrides.samples_per_side=200",
    )
    parser.add_argument(
        "--licence", default="CC-BY-4.0", help="licence named in the card (default CC-BY-4.0)"
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument("--json", action="store_true", help="print the summary as JSON")


def parse_overrides(items: list[str] | None) -> tuple[tuple[str, object], ...]:
    """``KEY=VALUE`` items -> ((key, value), ...); VALUE is read as a TOML value (3, 0.5,
    true, [1.0, 2.0], "text"), else kept as a plain string."""
    import tomllib

    def coerce(text: str):
        try:
            return tomllib.loads(f"v = {text}")["v"]
        except tomllib.TOMLDecodeError:
            return text.strip()

    out = []
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise ValueError(
                f"--set {item!r} is not allowed; allowed: KEY=VALUE, e.g. world.seed=3"
            )
        out.append((key.strip(), coerce(value)))
    return tuple(out)


def run(args: argparse.Namespace) -> int:
    from sim.dataset import DatasetConfig, build_dataset

    try:
        cfg = DatasetConfig(
            scenario=args.scenario,
            frames=args.frames,
            seed=args.seed,
            kind=args.kind,
            tile_pings=args.tile_pings,
            fls_view=args.fls_view,
            fls_interval_s=args.fls_interval,
            shard_frames=args.shard_frames,
            segmentation=args.segmentation,
            save_linear=args.npy,
            min_objects=args.min_objects,
            spread=not args.no_spread,
            overrides=parse_overrides(args.overrides),
            licence=args.licence,
        )
        use_ray = args.ray_address is not None
        address = None if args.ray_address in (None, "local") else args.ray_address
        res = build_dataset(
            cfg,
            args.out,
            workers=args.workers,
            use_ray=use_ray,
            ray_address=address,
            progress=not args.no_progress,
            force=args.force,
        )
    except (ValueError, RuntimeError) as exc:
        print(f"undersea dataset: {exc}", file=sys.stderr)
        return 2
    summary = {
        "out": str(res.out_dir),
        "frames": res.n_frames,
        "images": res.n_images,
        "annotations": res.n_annotations,
        "shards_done": len(res.shards_done),
        "shards_resumed": len(res.shards_resumed),
        "wall_s": round(res.wall_s, 3),
        "frames_per_s": res.frames_per_s,
    }
    if args.json:
        print_json(summary, indent=1)
    else:
        fps = f", {res.frames_per_s:.2f} frames/s" if res.frames_per_s else ""
        print(
            f"dataset {cfg.scenario}: {res.n_frames} frames, {res.n_images} images, "
            f"{res.n_annotations} instances ({len(res.shards_done)} shard(s) now, "
            f"{len(res.shards_resumed)} resumed; {res.wall_s:.1f} s{fps}) -> {res.out_dir}"
        )
    return 0

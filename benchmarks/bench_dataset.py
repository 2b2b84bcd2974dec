"""Dataset export throughput: frames/s serial vs 2 local worker processes vs local Ray with
2 workers, side by side on the same dataset settings; also checks that every mode wrote
the same bytes.

    undersea bench dataset [--scenario shipwreck-survey] [--kind sss] [--frames 64]
                           [--shard-frames 16] [--tile-pings 64] [--set KEY=VALUE ...] [--json]

Wall time includes process start-up, world building and the flight to each shard's offset
(physics + guidance only, reported separately as ``warmup_sim_s``), i.e. what a user waits.
Target (issue 7, for sweeps; the same execution layer): >= 1.8x with 2 workers. On a
loaded machine the measured ratio mostly shows the load; ``*_cpu_s`` and
``local-2_speedup_if_2_free_cores`` (serial CPU / half the workers' CPU) show what the
split itself costs (one extra interpreter start-up and import per worker).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import sys
import tempfile
from pathlib import Path


def _files(root: Path) -> dict[str, bytes]:
    return {
        str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()
    }


def _sources() -> dict[str, bytes]:
    """The simulator's sources: if they change during the benchmark (someone editing the
    working tree), byte identity across modes cannot be expected."""
    root = Path(__file__).resolve().parents[1] / "sim"
    return {str(p): p.read_bytes() for p in sorted(root.rglob("*.py"))}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="undersea bench dataset")
    ap.add_argument("--scenario", default="shipwreck-survey")
    ap.add_argument("--kind", default="sss")
    ap.add_argument("--frames", type=int, default=64)
    ap.add_argument("--shard-frames", type=int, default=16)
    ap.add_argument("--tile-pings", type=int, default=64)
    ap.add_argument("--fls-view", default="polar")
    ap.add_argument("--min-objects", type=int, default=0)
    ap.add_argument("--no-spread", action="store_true")
    ap.add_argument("--set", dest="overrides", action="append", metavar="KEY=VALUE")
    ap.add_argument("--no-ray", action="store_true")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)

    from sim.cli.dataset_cmd import parse_overrides
    from sim.dataset import DatasetConfig, build_dataset, plan_dataset

    cfg = DatasetConfig(
        args.scenario,
        frames=args.frames,
        seed=1,
        kind=args.kind,
        tile_pings=args.tile_pings,
        fls_view=args.fls_view,
        shard_frames=args.shard_frames,
        min_objects=args.min_objects,
        spread=not args.no_spread,
        overrides=parse_overrides(args.overrides),
    )
    jobs = plan_dataset(cfg)
    modes = [("serial", {"workers": 1}), ("local-2", {"workers": 2})]
    if not args.no_ray:
        try:
            import ray  # noqa: F401

            modes.append(("ray-local-2", {"workers": 2, "use_ray": True}))
        except ImportError:
            print(
                "ray not installed: skipping the Ray mode (pip install 'undersea[cluster]')",
                file=sys.stderr,
            )
    figures: dict = {
        "load_average_1min": os.getloadavg()[0],
        "cpus": os.cpu_count(),
        "scenario": args.scenario,
        "kind": args.kind,
        "frames": args.frames,
        "shards": len(jobs),
        "tile_pings": args.tile_pings,
        "warmup_sim_s": round(sum(j.offset_s for j in jobs), 3),
    }
    outputs = {}
    src0 = _sources()
    with tempfile.TemporaryDirectory() as tmp:
        for name, kw in modes:
            c0 = (
                resource.getrusage(resource.RUSAGE_SELF),
                resource.getrusage(resource.RUSAGE_CHILDREN),
            )
            res = build_dataset(cfg, Path(tmp) / name, progress=False, **kw)
            c1 = (
                resource.getrusage(resource.RUSAGE_SELF),
                resource.getrusage(resource.RUSAGE_CHILDREN),
            )
            if name != "ray-local-2":  # Ray workers are not our children: no CPU figure
                figures[f"{name}_cpu_s"] = sum(
                    (b.ru_utime + b.ru_stime) - (a.ru_utime + a.ru_stime) for a, b in zip(c0, c1)
                )
            figures[f"{name}_wall_s"] = res.wall_s
            figures[f"{name}_frames_per_s"] = res.frames_per_s
            figures["images"] = res.n_images
            figures["annotations"] = res.n_annotations
            outputs[name] = _files(Path(tmp) / name)
    base = figures["serial_frames_per_s"]
    for name, _ in modes[1:]:
        figures[f"{name}_speedup"] = figures[f"{name}_frames_per_s"] / base
    src1 = _sources()
    figures["sources_changed_during_bench"] = sorted(
        Path(k).name for k in set(src0) | set(src1) if src0.get(k) != src1.get(k)
    )
    if "local-2_cpu_s" in figures:
        # what 2 free cores would give if the work splits evenly: serial CPU / (CPU of both
        # workers / 2) -- an estimate for a loaded machine, next to the measured ratio
        figures["local-2_speedup_if_2_free_cores"] = figures["serial_cpu_s"] / (
            figures["local-2_cpu_s"] / 2
        )
    ref = outputs["serial"]
    figures["identical_bytes_across_modes"] = all(o == ref for o in outputs.values())
    figures["differing_files"] = sorted(
        {k for o in outputs.values() for k in set(o) | set(ref) if o.get(k) != ref.get(k)}
    )[:5]
    if args.json:
        print(json.dumps(figures, indent=1))
    else:
        for k, v in figures.items():
            print(f"{k:>30}: {v:.3f}" if isinstance(v, float) else f"{k:>30}: {v}")
        print("target: speedup >= 1.8 with 2 workers")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""``undersea run SCENARIO``, ``undersea demo`` and ``undersea scenarios``.

``run`` validates the scenario (a built-in name or a .toml path), runs it headless and
writes ``DIR/recording.rrd``, ``DIR/metrics.json`` and PNG figures (see sim.runner).
``demo`` runs a one-minute cut of the default scenario (shipwreck-survey: the first
survey line, past a rock and the wreck) into ``runs/demo``; ``--full`` runs the whole
450 s survey. Both refuse to replace an existing output unless ``--overwrite``.
``scenarios`` lists the built-ins with their descriptions.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from sim.cli.common import finite_float, print_json

DEFAULT_SCENARIO = "shipwreck-survey"

DEMO_OUT = Path("runs") / "demo"
#: the quick demo: the first survey line of shipwreck-survey, shortened to pass a rock and
#: the wreck in 60 simulated seconds (well under a minute of wall time on 2 cores)
DEMO_OVERRIDES = {
    "duration_s": 60.0,
    "vehicles[0].start.position": [-40.0, -30.0, -22.0],
    "vehicles[0].mission.center": [30.0, 0.0],
}

#: what each output file is, printed after a run
OUTPUT_FILES = {
    "recording.rrd": "rerun recording: 3-D world, vehicle, sonar images, SLAM map",
    "metrics.json": "ATE, NEES, landmark RMSE, detection PPV (README: what good looks like)",
    "trajectory_map.png": "true / dead-reckoned / SLAM trajectories and landmarks",
    "sss_mosaic.png": "side-scan mosaic of the survey",
}


def add_command_arguments(name: str, parser: argparse.ArgumentParser) -> None:
    if name == "scenarios":
        parser.add_argument("--json", action="store_true", help="print the list as JSON")
        return
    if name == "run":
        parser.add_argument(
            "scenario", help="built-in scenario name (see `undersea scenarios`) or a .toml file"
        )
    default_out = str(DEMO_OUT) if name == "demo" else "runs/<scenario>-seed<N>"
    parser.add_argument(
        "--out", type=Path, default=None, help=f"output directory (default: {default_out})"
    )
    if name == "demo":
        parser.add_argument(
            "--full", action="store_true", help="the whole 450 s survey instead of one minute"
        )
    parser.add_argument("--seed", type=int, default=None, help="override the scenario's seed")
    parser.add_argument(
        "--duration", type=finite_float, default=None, help="override the simulated duration, s"
    )
    parser.add_argument(
        "--overwrite",
        action="store_true",
        help="replace the output directory if it exists (default: refuse and exit 2)",
    )
    parser.add_argument(
        "--no-progress",
        action="store_true",
        help="no progress output (default: a bar on a terminal, else a line every 5 s on stderr)",
    )


def run_command(name: str, args: argparse.Namespace) -> int:
    from sim.scenario import ScenarioError, builtin_scenarios, load_scenario

    if name == "scenarios":
        items = {n: load_scenario(p).description for n, p in builtin_scenarios().items()}
        if args.json:
            print_json(items, indent=2)
        else:
            width = max(map(len, items), default=0)
            for n, desc in items.items():
                mark = " (default)" if n == DEFAULT_SCENARIO else ""
                print(f"{n:<{width}}  {desc}{mark}")
        return 0
    scenario_name = DEFAULT_SCENARIO if name == "demo" else args.scenario
    quick = name == "demo" and not args.full
    try:
        scenario = load_scenario(
            scenario_name, overrides=DEMO_OVERRIDES if quick else None
        ).with_overrides(seed=args.seed, duration_s=args.duration)
    except ScenarioError as exc:
        print(f"undersea {name}: {exc}", file=sys.stderr)
        return 2
    out = args.out
    if out is None:
        out = DEMO_OUT if name == "demo" else Path("runs") / f"{scenario.name}-seed{scenario.seed}"
    from sim.runner import OutputExistsError, run_scenario

    try:
        result = run_scenario(
            scenario,
            out,
            overwrite=args.overwrite,
            progress=None if not args.no_progress else False,
        )
    except OutputExistsError as exc:
        print(f"undersea {name}: {exc}", file=sys.stderr)
        return 2
    print(result.summary())
    print(describe_outputs(result.out_dir))
    return 0 if result.complete else 130


def describe_outputs(out_dir: Path) -> str:
    """Where the run wrote what, and the next command to try."""
    lines = [f"wrote {out_dir}/:"]
    for f in sorted(Path(out_dir).iterdir()):
        lines.append(f"  {f.name:<20} {OUTPUT_FILES.get(f.name, '')}".rstrip())
    if (Path(out_dir) / "recording.rrd").exists():
        lines.append(f"next: undersea view {out_dir}")
    return "\n".join(lines)

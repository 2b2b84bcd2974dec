"""``undersea run SCENARIO``, ``undersea demo`` and ``undersea scenarios``.

``run`` validates the scenario (a built-in name or a .toml path), runs it headless and
writes ``DIR/recording.rrd``, ``DIR/metrics.json`` and PNG figures (see sim.runner).
``demo`` runs the default scenario (shipwreck-survey) with no arguments.
``scenarios`` lists the built-ins with their descriptions.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

HELP = "run a scenario headless (run), the default scenario (demo), or list built-ins (scenarios)"
DEFAULT_SCENARIO = "shipwreck-survey"

_HELPS = {
    "run": "run a scenario headless: writes DIR/recording.rrd, DIR/metrics.json and figures",
    "demo": f"run the default scenario ({DEFAULT_SCENARIO}) into ./runs/demo",
    "scenarios": "list the built-in scenarios",
}


def add_command_arguments(name: str, parser: argparse.ArgumentParser) -> None:
    parser.description = _HELPS[name]
    if name == "scenarios":
        parser.add_argument("--json", action="store_true", help="print the list as JSON")
        return
    if name == "run":
        parser.add_argument(
            "scenario", help="built-in scenario name (see `undersea scenarios`) or a .toml file"
        )
    parser.add_argument(
        "--out", type=Path, default=None, help="output directory (default: runs/<scenario>-seed<N>)"
    )
    parser.add_argument("--seed", type=int, default=None, help="override the scenario's seed")
    parser.add_argument(
        "--duration", type=float, default=None, help="override the simulated duration, s"
    )
    parser.add_argument(
        "--overwrite", action="store_true", help="replace an existing output directory"
    )
    parser.add_argument(
        "--no-progress",
        action="store_true",
        help="no progress bar (also off when not a TTY or CI=true)",
    )


def run_command(name: str, args: argparse.Namespace) -> int:
    from sim.scenario import ScenarioError, builtin_scenarios, load_scenario

    if name == "scenarios":
        items = {n: load_scenario(p).description for n, p in builtin_scenarios().items()}
        if args.json:
            print(json.dumps(items, indent=2))
        else:
            width = max(map(len, items), default=0)
            for n, desc in items.items():
                mark = " (default)" if n == DEFAULT_SCENARIO else ""
                print(f"{n:<{width}}  {desc}{mark}")
        return 0
    scenario_name = DEFAULT_SCENARIO if name == "demo" else args.scenario
    try:
        scenario = load_scenario(scenario_name).with_overrides(
            seed=args.seed, duration_s=args.duration
        )
    except ScenarioError as exc:
        print(f"undersea {name}: {exc}", file=sys.stderr)
        return 2
    out = args.out
    if out is None:
        out = Path("runs") / ("demo" if name == "demo" else f"{scenario.name}-seed{scenario.seed}")
    from sim.runner import OutputExistsError, run_scenario

    try:
        result = run_scenario(
            scenario,
            out,
            overwrite=args.overwrite or name == "demo",
            progress=None if not args.no_progress else False,
        )
    except OutputExistsError as exc:
        print(f"undersea {name}: {exc}", file=sys.stderr)
        return 2
    print(result.summary())
    return 0 if result.complete else 130

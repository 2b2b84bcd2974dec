"""Entry point of the ``undersea`` command.

Each subcommand is a module ``sim.cli.<module>`` exposing

* ``HELP: str`` — one line for ``undersea --help``;
* ``add_arguments(parser: argparse.ArgumentParser) -> None``;
* ``run(args: argparse.Namespace) -> int`` — the exit code.

Modules are imported lazily, only when their command runs, so ``undersea segment`` never
pays for importing mujoco and a broken optional extra breaks only its own command.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

#: command name -> module under sim.cli
COMMANDS: dict[str, str] = {
    "demo": "run_cmd",
    "run": "run_cmd",
    "scenarios": "run_cmd",
    "view": "view_cmd",
    "segment": "segment_cmd",
    "normalize": "normalize_cmd",
    "match": "match_cmd",
    "uwsn": "uwsn_cmd",
    "slam-experiment": "slam_experiment_cmd",
    "sss-slam": "sss_slam_cmd",
    "bench": "bench_cmd",
    "sweep": "sweep_cmd",
    "dataset": "dataset_cmd",
    "realism": "realism_cmd",
    "calibrate": "calibrate_cmd",
}


def _load(command: str):
    module = importlib.import_module(f"sim.cli.{COMMANDS[command]}")
    return module


def build_parser(argv: Sequence[str]) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="undersea",
        description="undersea: underwater sonar simulation and sonar-based landmark SLAM.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    wanted = next((a for a in argv if not a.startswith("-")), None)
    for name in COMMANDS:
        # Only the command being run is imported; others get a placeholder help line.
        if name == wanted:
            try:
                module = _load(name)
            except ModuleNotFoundError as exc:
                if exc.name and exc.name.startswith("sim.cli."):
                    raise SystemExit(f"undersea: command {name!r} is not available yet") from exc
                raise SystemExit(
                    f"undersea {name}: missing dependency {exc.name!r}: {exc}"
                ) from exc
            helptext = getattr(module, "HELP", name)
            p = sub.add_parser(name, help=helptext, description=helptext)
            if hasattr(module, "add_command_arguments"):
                module.add_command_arguments(name, p)
            else:
                module.add_arguments(p)
            p.set_defaults(_module=module)
        else:
            sub.add_parser(name, help=f"(see: undersea {name} --help)", add_help=False)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser(argv)
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 2
    module = args._module
    if hasattr(module, "run_command"):
        return int(module.run_command(args.command, args) or 0)
    return int(module.run(args) or 0)


if __name__ == "__main__":
    sys.exit(main())

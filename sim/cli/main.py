"""Entry point of the ``undersea`` command.

:data:`COMMANDS` is the one home of each command's name, module and one-line help. The
module ``sim.cli.<module>`` exposes

* ``add_arguments(parser: argparse.ArgumentParser) -> None`` (or
  ``add_command_arguments(name, parser)`` when one module serves several commands);
* ``run(args: argparse.Namespace) -> int`` (or ``run_command(name, args)``) — the exit code.

Only the chosen command's module is imported (``undersea --help`` and ``--version`` import
none), and command modules import their heavy dependencies (mujoco, scipy, rerun, cv2,
matplotlib, ...) inside ``run``: ``undersea segment`` never pays for importing mujoco and a
broken optional extra breaks only its own command.

Errors: a :class:`sim.cli.common.CliError`, ``ValueError`` (``ScenarioError`` included)
or ``OSError`` raised by a command is bad input: one line ``undersea CMD: message`` on
stderr and exit code 2 (``UNDERSEA_DEBUG=1`` shows the traceback instead). A closed
stdout (``undersea ... | head``) ends the command quietly.
"""

from __future__ import annotations

import argparse
import importlib
import importlib.metadata
import os
import sys
from collections.abc import Sequence
from dataclasses import dataclass

from sim.cli.common import EXIT_USAGE, CliError, error


@dataclass(frozen=True)
class Command:
    """One ``undersea`` command: its module under ``sim.cli`` and its one-line help."""

    module: str
    help: str


#: command name -> its module and the line ``undersea --help`` shows for it
COMMANDS: dict[str, Command] = {
    "demo": Command(
        "run_cmd", "a one-minute survey over a wreck into ./runs/demo (--full: the 450 s survey)"
    ),
    "run": Command(
        "run_cmd",
        "run a scenario headless: writes DIR/recording.rrd, DIR/metrics.json and figures",
    ),
    "scenarios": Command("run_cmd", "list the built-in scenarios"),
    "view": Command(
        "view_cmd",
        "open a recording (.rrd or a run directory) in the rerun viewer (--web: in a browser)",
    ),
    "segment": Command(
        "segment_cmd",
        "segment sonar images (improved Otsu TSM or baselines); landmarks, thresholds, scores",
    ),
    "normalize": Command(
        "normalize_cmd",
        "normalize side-scan waterfalls (recordings, images or folders) with MIRA or DCP; "
        "print SIQEM before/after",
    ),
    "match": Command(
        "match_cmd",
        "match two sonar images (Harris, BRISK, SIFT, ORB or ASIFT keypoints), bidirectional "
        "NN ratio test and RANSAC",
    ),
    "uwsn": Command(
        "uwsn_cmd",
        "UWSN-DT map-fusion demo (3000 m field, 1000 nodes, scans at (500,500) and (600,600))",
    ),
    "slam-experiment": Command(
        "slam_experiment_cmd",
        "run the reference's simulated SLAM experiments (dense-loop, line, segmentation-loop)",
    ),
    "sss-slam": Command(
        "sss_slam_cmd",
        "run the segmentation front end and SLAM on a side-scan recording (XTF, JSF, "
        "Humminbird, Lowrance, Garmin; needs its navigation) or FLS .npy frames + JSON sidecar",
    ),
    "mosaic": Command(
        "mosaic_cmd",
        "georeferenced slant-range-corrected mosaic (GeoTIFF) of side-scan recordings or folders",
    ),
    "bench": Command(
        "bench_cmd",
        "run a speed benchmark (physics, sonar, frontend, slam, env, sweep) and print its figures",
    ),
    "sweep": Command(
        "sweep_cmd",
        "run Monte Carlo variants of a scenario or SLAM experiment in parallel and aggregate "
        "metrics",
    ),
    "dataset": Command(
        "dataset_cmd",
        "export labelled sonar frames (SSS tiles, FLS frames) with instance masks in COCO format",
    ),
    "realism": Command(
        "realism_cmd",
        "compare the realism statistics of two side-scan waterfalls (SIM against REAL)",
    ),
    "calibrate": Command(
        "calibrate_cmd",
        "fit a side-scan preset's realism levels to a real recording; write a preset TOML",
    ),
}


def load_command(name: str):
    """Import the module of command ``name``; a missing module or dependency ends the
    program with a message naming it."""
    try:
        return importlib.import_module(f"sim.cli.{COMMANDS[name].module}")
    except ModuleNotFoundError as exc:
        if exc.name and exc.name.startswith("sim.cli."):
            raise SystemExit(
                f"undersea: command {name!r}: module {exc.name} missing (broken install)"
            ) from exc
        raise SystemExit(f"undersea {name}: missing dependency {exc.name!r}: {exc}") from exc


def version() -> str:
    """The installed package version (``undersea --version``)."""
    try:
        return importlib.metadata.version("undersea")
    except importlib.metadata.PackageNotFoundError:
        return "unknown (not installed; run `pip install -e .`)"


def build_parser(argv: Sequence[str]) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="undersea",
        description="undersea: underwater sonar simulation and sonar-based landmark SLAM.",
        epilog="Start with `undersea demo`, then `undersea view runs/demo`. "
        "`undersea COMMAND --help` explains a command.",
    )
    parser.add_argument("--version", action="version", version=f"undersea {version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    wanted = next((a for a in argv if not a.startswith("-")), None)
    for name, command in COMMANDS.items():
        if name != wanted:  # listed for the top-level help; its module is not imported
            sub.add_parser(name, help=command.help, add_help=False)
            continue
        module = load_command(name)
        p = sub.add_parser(name, help=command.help, description=command.help)
        if hasattr(module, "add_command_arguments"):
            module.add_command_arguments(name, p)
        else:
            module.add_arguments(p)
        p.set_defaults(_module=module)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser(argv)
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return EXIT_USAGE
    module = args._module
    try:
        if hasattr(module, "run_command"):
            rc = int(module.run_command(args.command, args) or 0)
        else:
            rc = int(module.run(args) or 0)
        sys.stdout.flush()
    except BrokenPipeError:
        return _stdout_closed()
    except KeyboardInterrupt:
        print(f"undersea {args.command}: interrupted", file=sys.stderr)
        return 130
    except (CliError, ValueError, OSError) as exc:
        if os.environ.get("UNDERSEA_DEBUG"):
            raise
        text = str(exc) if isinstance(exc, CliError | ValueError) else _os_message(exc)
        return error(args.command, text)
    return rc


def _os_message(exc: OSError) -> str:
    where = f" {exc.filename!r}" if getattr(exc, "filename", None) else ""
    return f"{exc.strerror or exc}:{where}" if exc.strerror else str(exc)


def _stdout_closed() -> int:
    """The reader of stdout went away (``| head``): point stdout at /dev/null so the
    interpreter's final flush does not raise again, and end like SIGPIPE would."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())
    return 141


if __name__ == "__main__":
    sys.exit(main())

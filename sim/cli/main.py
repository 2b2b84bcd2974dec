"""Entry point of the ``undersea`` command.

Each subcommand is a module ``sim.cli.<module>`` exposing

* ``HELP: str`` — one line for ``undersea --help``;
* ``add_arguments(parser: argparse.ArgumentParser) -> None``;
* ``run(args: argparse.Namespace) -> int`` — the exit code.

Command modules import their heavy dependencies inside ``run``, so importing them for
the help text is cheap: ``undersea segment`` never pays for importing mujoco and a broken
optional extra breaks only its own command.

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

from sim.cli.common import EXIT_USAGE, CliError, error

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
    "mosaic": "mosaic_cmd",
    "bench": "bench_cmd",
    "sweep": "sweep_cmd",
    "dataset": "dataset_cmd",
    "realism": "realism_cmd",
    "calibrate": "calibrate_cmd",
}


def _load(command: str):
    module = importlib.import_module(f"sim.cli.{COMMANDS[command]}")
    return module


def version() -> str:
    """The installed package version (``undersea --version``)."""
    try:
        return importlib.metadata.version("undersea")
    except importlib.metadata.PackageNotFoundError:
        return "unknown (not installed; run `pip install -e .`)"


def command_help(name: str) -> str:
    """One line describing a command, from its module's ``HELP`` (or ``COMMAND_HELPS``)."""
    try:
        module = _load(name)
    except ImportError as exc:
        return f"(unavailable: {exc})"
    return getattr(module, "COMMAND_HELPS", {}).get(name, module.HELP)


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
    for name in COMMANDS:
        # Only the command being run is imported; others get a placeholder help line.
        if name == wanted:
            try:
                module = _load(name)
            except ModuleNotFoundError as exc:
                if exc.name and exc.name.startswith("sim.cli."):
                    raise SystemExit(f"undersea: command {name!r}: module {exc.name} missing (broken install)") from exc
                raise SystemExit(
                    f"undersea {name}: missing dependency {exc.name!r}: {exc}"
                ) from exc
            helptext = command_help(name)
            p = sub.add_parser(name, help=helptext, description=helptext)
            if hasattr(module, "add_command_arguments"):
                module.add_command_arguments(name, p)
            else:
                module.add_arguments(p)
            p.set_defaults(_module=module)
        else:
            sub.add_parser(name, help=command_help(name), add_help=False)
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

"""What every ``undersea`` command shares: the error type that becomes "message on stderr,
exit 2", strict JSON output (NaN -> null), and checks of output paths before any work."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

#: exit code of bad input (argparse uses the same)
EXIT_USAGE = 2


class CliError(Exception):
    """Bad input found by a command; ``undersea`` prints the message and exits 2."""


def print_json(obj: Any, *, indent: int | None = None) -> None:
    """Print ``obj`` as one strict JSON document (NaN/inf -> null, numpy -> Python)."""
    from sim.jsonsafe import dumps  # numpy: not imported for `undersea --help`

    print(dumps(obj, indent=indent))


def writable_file(path: str | Path | None, option: str) -> Path | None:
    """Check that ``path`` can be created (its folder exists and is a folder), before any
    work is done; ``option`` names the flag in the message. None passes through."""
    if path is None:
        return None
    p = Path(path)
    parent = p.parent if str(p.parent) else Path(".")
    if p.is_dir():
        raise CliError(f"{option} {str(path)!r}: is a directory; allowed: a file path")
    if not parent.is_dir():
        raise CliError(
            f"{option} {str(path)!r}: folder {str(parent)!r} does not exist; "
            "allowed: a file path in an existing folder"
        )
    return p


def error(command: str, message: object) -> int:
    """Print ``undersea COMMAND: message`` on stderr; return the usage exit code."""
    print(f"undersea {command}: {message}", file=sys.stderr)
    return EXIT_USAGE


def finite_float(text: str) -> float:
    """argparse type: a finite number (``nan``/``inf`` rejected with argparse's exit 2)."""
    import argparse
    import math

    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"got {text!r}; allowed: a number") from None
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError(f"got {text!r}; allowed: a finite number")
    return v

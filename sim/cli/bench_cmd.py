"""``undersea bench TARGET [--json] [...]``: run a benchmark script from ``benchmarks/``.

Benchmarks live in the source checkout (``benchmarks/bench_<target>.py``, each with a
``main(argv) -> int`` that prints its figures); they are not installed with a wheel.
"""

from __future__ import annotations

import argparse
import importlib.util
from pathlib import Path

from sim.cli.common import CliError


def benchmarks_dir() -> Path:
    return Path(__file__).resolve().parents[2] / "benchmarks"


def available() -> list[str]:
    d = benchmarks_dir()
    return sorted(p.stem.removeprefix("bench_") for p in d.glob("bench_*.py")) if d.is_dir() else []


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("target", help="benchmark name: " + ", ".join(available() or ["(none found)"]))
    parser.add_argument("rest", nargs=argparse.REMAINDER, help="arguments passed to the benchmark")


def run(args: argparse.Namespace) -> int:
    path = benchmarks_dir() / f"bench_{args.target}.py"
    if not path.is_file():
        names = available()
        if not benchmarks_dir().is_dir():
            raise CliError(
                "benchmarks ship with the source checkout "
                f"(expected them in {benchmarks_dir()})"
            )
        raise CliError(
            f"unknown target {args.target!r}; allowed: {', '.join(names) or '(none yet)'}"
        )
    spec = importlib.util.spec_from_file_location(f"bench_{args.target}", path)
    module = importlib.util.module_from_spec(spec)
    assert spec.loader is not None
    spec.loader.exec_module(module)
    return int(module.main(list(args.rest)) or 0)

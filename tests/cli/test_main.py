"""The CLI dispatcher: every registered command module exists and loads its parser, and
only the chosen command's module (and none of the heavy libraries) is imported for help."""

from __future__ import annotations

import importlib
import os
import subprocess
import sys
from pathlib import Path

import pytest

from sim.cli.main import COMMANDS, main


def test_help_lists_every_command(capsys):
    assert main([]) == 2
    out = capsys.readouterr().out
    for name in COMMANDS:
        assert name in out


def test_bench_unknown_target_names_allowed_values(capsys):
    assert main(["bench", "nope"]) == 2
    assert "unknown target 'nope'; allowed" in capsys.readouterr().err


@pytest.mark.parametrize("name", sorted({c.module for c in COMMANDS.values()}))
def test_command_module_has_interface(name):
    try:
        module = importlib.import_module(f"sim.cli.{name}")
    except ModuleNotFoundError as exc:
        if exc.name == f"sim.cli.{name}":
            pytest.skip(f"sim.cli.{name} not written yet")
        raise
    assert hasattr(module, "add_arguments") or hasattr(module, "add_command_arguments")
    assert hasattr(module, "run") or hasattr(module, "run_command")
    assert not hasattr(module, "HELP"), "the one-line help lives in sim.cli.main.COMMANDS"


def test_every_command_has_a_one_line_help():
    for name, command in COMMANDS.items():
        assert command.help.strip() and "\n" not in command.help, name


REPO = Path(__file__).resolve().parents[2]
#: libraries a help text must not import (seconds of start-up each on 2 busy cores)
HEAVY = ("mujoco", "scipy", "scipy.stats", "rerun", "cv2", "numba", "matplotlib", "ray")
#: run `undersea ARGS` in this process, then list which sim.cli modules and which HEAVY
#: libraries it imported (sys.modules, not timing)
DRIVER = """
import sys
from sim.cli.main import main
try:
    main(sys.argv[1:])
except SystemExit:
    pass
heavy = {heavy!r}
print("MODULES", *sorted(m for m in sys.modules if m.startswith("sim.cli.")))
print("HEAVY", *[m for m in heavy if m in sys.modules])
"""


def _imported(*args: str) -> tuple[set[str], set[str]]:
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    proc = subprocess.run(
        [sys.executable, "-c", DRIVER.format(heavy=HEAVY), *args],
        capture_output=True,
        text=True,
        env=env,
        cwd=REPO,  # `-c` puts the working directory first on sys.path
        timeout=120,
    )
    lines = dict(
        line.split(" ", 1) if " " in line else (line, "")
        for line in proc.stdout.splitlines()
        if line.startswith(("MODULES", "HEAVY"))
    )
    assert set(lines) == {"MODULES", "HEAVY"}, proc.stdout + proc.stderr
    return set(lines["MODULES"].split()), set(lines["HEAVY"].split())


@pytest.mark.parametrize(
    "args, command_module",
    [
        (("--version",), None),
        (("--help",), None),
        (("normalize", "--help"), "sim.cli.normalize_cmd"),
        (("run", "--help"), "sim.cli.run_cmd"),
        (("realism", "--help"), "sim.cli.realism_cmd"),
        (("view", "--help"), "sim.cli.view_cmd"),
    ],
)
def test_help_imports_only_the_chosen_command_and_no_heavy_library(args, command_module):
    modules, heavy = _imported(*args)
    commands = {m for m in modules if m.endswith("_cmd")}
    assert commands == ({command_module} if command_module else set())
    assert heavy == set(), f"`undersea {' '.join(args)}` imported {sorted(heavy)}"

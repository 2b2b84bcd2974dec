"""The CLI dispatcher: every registered command module exists and loads its parser."""

from __future__ import annotations

import importlib

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


@pytest.mark.parametrize("name", sorted(set(COMMANDS.values())))
def test_command_module_has_interface(name):
    try:
        module = importlib.import_module(f"sim.cli.{name}")
    except ModuleNotFoundError as exc:
        if exc.name == f"sim.cli.{name}":
            pytest.skip(f"sim.cli.{name} not written yet")
        raise
    assert isinstance(module.HELP, str) and module.HELP
    assert hasattr(module, "run") or hasattr(module, "run_command")

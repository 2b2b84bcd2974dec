"""CLI: undersea scenarios / run / demo / view (run_cmd.py, view_cmd.py)."""

from __future__ import annotations

import json

import pytest

from sim.cli.main import main


def test_scenarios_lists_the_builtins(capsys):
    assert main(["scenarios", "--json"]) == 0
    items = json.loads(capsys.readouterr().out)
    assert {"shipwreck-survey", "dense-loop", "harbour-fls", "swarms-mapping"} <= set(items)


def test_run_bad_scenario_names_builtins(capsys):
    assert main(["run", "no-such-scenario"]) == 2
    err = capsys.readouterr().err
    assert "no-such-scenario" in err and "shipwreck-survey" in err


def test_run_bad_toml_field(tmp_path, capsys):
    p = tmp_path / "bad.toml"
    p.write_text('[world]\nseabed = "lava"\n[[vehicles]]\nkind = "alister9"\n')
    assert main(["run", str(p), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "world.seabed" in err and "'lava'" in err and "ripples" in err
    assert not (tmp_path / "o").exists()


def test_run_short_writes_outputs(tmp_path, capsys):
    out = tmp_path / "r"
    assert (
        main(
            [
                "run",
                "shipwreck-survey",
                "--out",
                str(out),
                "--duration",
                "1.5",
                "--seed",
                "4",
                "--no-progress",
            ]
        )
        == 0
    )
    m = json.loads((out / "metrics.json").read_text())
    assert m["seed"] == 4 and m["complete"] and m["sim_time_s"] == pytest.approx(1.5)
    assert (out / "recording.rrd").is_file()
    assert "complete" in capsys.readouterr().out
    assert main(["run", "shipwreck-survey", "--out", str(out), "--duration", "1.5"]) == 2  # exists


def test_view_without_display_explains(tmp_path, monkeypatch, capsys):
    from sim.cli import view_cmd

    monkeypatch.setattr(view_cmd, "has_display", lambda: False)
    rrd = tmp_path / "recording.rrd"
    rrd.write_bytes(b"")
    assert main(["view", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "no display" in err and "--web" in err
    assert main(["view", str(tmp_path / "missing.rrd")]) == 2
    assert "no recording at" in capsys.readouterr().err

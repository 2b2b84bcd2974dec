"""Validation at load time (issue 15): what the scenario file decides about the seabed is
checked when it is read, with the field-naming message (exit 2 from the CLI), never as a
traceback at world build with a `.partial` left behind."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim.cli.main import main
from sim.scenario import ScenarioError, load_scenario, load_scenario_dict, parse_scenario
from sim.scenario.seabed_check import START_CLEARANCE_M, seabed_resolution


def _grid_scenario(grid_path, depth=30.0, start=(0.0, 0.0, -5.0), objects=()) -> dict:
    return {
        "world": {
            "seabed": "grid",
            "grid_path": str(grid_path),
            "size_m": [40.0, 40.0],
            "depth_m": depth,
            "objects": [{"class": "rock", "position": list(p)} for p in objects],
        },
        "vehicles": [{"kind": "alister9", "start": {"position": list(start)}}],
    }


def _err(data) -> str:
    with pytest.raises(ScenarioError) as ei:
        parse_scenario(data)
    return str(ei.value)


@pytest.mark.parametrize(
    ("content", "expect"),
    [
        (None, "existing .npy file"),
        (b"\x93NUMPY garbage that is not an array header", "readable .npy"),
        (np.full((10, 10), np.nan), "non-finite"),
        (np.full((1, 1), 20.0), ">= 2 rows and columns"),
        (np.full((4, 4), -3.0), "> 0"),
    ],
    ids=["missing", "corrupt", "nan", "1x1", "negative"],
)
def test_bad_grid_file_fails_at_load_naming_the_field(tmp_path, content, expect):
    path = tmp_path / "depth.npy"
    if isinstance(content, bytes):
        path.write_bytes(content)
    elif content is not None:
        np.save(path, content)
    msg = _err(_grid_scenario(path))
    assert "world.grid_path" in msg and expect in msg and str(path) in msg


def test_start_below_a_grid_seabed(tmp_path):
    """A 10 m deep grid in a world declared 30 m deep: z = -15 m is inside the seabed."""
    path = tmp_path / "depth.npy"
    np.save(path, np.full((41, 41), 10.0))
    msg = _err(_grid_scenario(path, start=(0.0, 0.0, -15.0)))
    assert "vehicles[0].start.position[2]" in msg and "seabed at z = -10.00" in msg
    parse_scenario(_grid_scenario(path, start=(0.0, 0.0, -9.0)))  # above it: fine


def test_object_off_a_small_grid(tmp_path):
    """A 5 x 5 grid spans 4 cells of the world's grid spacing; an object 15 m out is off it."""
    path = tmp_path / "depth.npy"
    np.save(path, np.full((5, 5), 20.0))
    half = 2 * seabed_resolution((40.0, 40.0))
    msg = _err(_grid_scenario(path, start=(0.0, 0.0, -5.0), objects=[(15.0, 0.0)]))
    assert "world.objects[0].position[0]" in msg and f"{half:g}" in msg


def test_start_below_a_sloped_seabed():
    """harbour-fls: 12 m deep, 5 deg slope falling towards +x (SeabedSpec defaults), so
    at x = -39 m the seabed is at -12 + 39 tan(5 deg) = -8.59 m; z = -9 is inside it
    although it is above -depth_m (the only check before)."""
    data = load_scenario_dict("harbour-fls")
    data["vehicles"][0]["start"]["position"] = [-39.0, -20.0, -9.0]
    msg = _err(data)
    floor = -12.0 + 39.0 * math.tan(math.radians(5.0))
    assert "vehicles[0].start.position[2]" in msg
    assert f"{floor + START_CLEARANCE_M:.2f}" in msg  # within the 0.02 m roughness
    data["vehicles"][0]["start"]["position"] = [-39.0, -20.0, -7.5]
    parse_scenario(data)


def test_non_utf8_toml_names_the_file_and_byte(tmp_path):
    p = tmp_path / "latin1.toml"
    p.write_bytes('name = "épave"\n'.encode("latin-1"))
    with pytest.raises(ScenarioError, match=r"latin1.toml.*byte 8 is not UTF-8"):
        load_scenario(p)


def test_cli_exit_2_and_no_partial_for_a_bad_grid(tmp_path, capsys):
    grid = tmp_path / "depth.npy"
    np.save(grid, np.full((10, 10), np.nan))
    toml = tmp_path / "bad.toml"
    toml.write_text(
        f'[world]\nseabed = "grid"\ngrid_path = "{grid}"\nsize_m = [40.0, 40.0]\n'
        '[[vehicles]]\nkind = "alister9"\n'
    )
    out = tmp_path / "out"
    assert main(["run", str(toml), "--out", str(out), "--no-progress"]) == 2
    assert "world.grid_path" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.toml", "depth.npy"]


def test_cli_non_utf8_exit_2(tmp_path, capsys):
    p = tmp_path / "bad.toml"
    p.write_bytes(b'name = "\xff"\n')
    assert main(["run", str(p), "--out", str(tmp_path / "o")]) == 2
    assert "not UTF-8" in capsys.readouterr().err

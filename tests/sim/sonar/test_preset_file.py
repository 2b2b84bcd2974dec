"""Preset files (calibrated presets): a scenario names one by path or shipped stem and gets
the base preset with the file's overrides, its own overrides on top; bad files are named."""

from __future__ import annotations

import pytest

from sim.scenario import ScenarioError, load_scenario_dict, parse_scenario
from sim.sonar.config import preset
from sim.sonar.preset_file import calibrated_presets, load_preset_file

FILE = """# written by hand in the format of `undersea calibrate`
[sonar]
preset = "deepeye680d_realistic"

[sonar.overrides]
texture_db = 3.25
receiver_gain_db = -4.5
volume_sv_db = "off"

[calibration]
recording = "somewhere.xtf"
"""


def _scenario_with(preset_name: str, overrides: dict | None = None) -> dict:
    d = load_scenario_dict("shipwreck-survey")
    d["vehicles"][0]["sonars"][0] = {"preset": preset_name, "overrides": overrides or {}}
    return d


def test_scenario_preset_by_path_applies_file_then_scenario_overrides(tmp_path):
    p = tmp_path / "my_sonar.toml"
    p.write_text(FILE)
    spec = parse_scenario(_scenario_with(str(p), {"max_range": 35.0, "texture_db": 2.0}))
    sp = spec.vehicles[0].sonars[0]
    assert sp.preset == "deepeye680d_realistic" and sp.source == str(p) and sp.is_sidescan
    got = preset(sp.preset, **dict(sp.overrides))
    rz = got.acoustic.realism
    # independent expectation: the base preset's own values, replaced field by field
    assert got.max_range == 35.0
    assert rz.texture_db == 2.0  # the scenario's override wins over the file's 3.25
    assert rz.receiver_gain_db == -4.5 and rz.volume_sv_db is None
    assert rz.range_cell_m == preset("deepeye680d_realistic").acoustic.realism.range_cell_m


def test_file_written_by_calibrate_loads(tmp_path):
    """The writer of `undersea calibrate` and the reader agree on the format."""
    import argparse

    from sim.cli.calibrate_cmd import preset_toml

    args = argparse.Namespace(model="raycast", preset="deepeye680d_realistic")
    values = {None: {"texture_db": 4.0, "range_cell_m": 0.01}}
    text = preset_toml(args, values, _NoStats(), _NoStats(), {"recording": "r"})
    p = tmp_path / "cal.toml"
    p.write_text(text)
    pf = load_preset_file(p)
    assert pf.base == "deepeye680d_realistic"
    assert pf.overrides == {"texture_db": 4.0, "range_cell_m": 0.01}
    assert pf.config().acoustic.realism.range_cell_m == 0.01


class _NoStats:
    def sides(self):
        return {}


def test_per_side_file_written_by_calibrate_loads_per_side_and_not_in_a_scenario(tmp_path):
    """`undersea calibrate --per-side` writes each side's values in its own table over the
    common overrides; read back per side they give each side's config; a scenario (one
    config for both sides) refuses the file with a message saying why."""
    import argparse

    from sim.cli.calibrate_cmd import preset_toml

    args = argparse.Namespace(model="raycast-display", preset="deepeye680d_realistic")
    values = {
        "port": {"texture_db": 0.5, "display_floor_db": 100.0},
        "starboard": {"texture_db": 2.0, "display_floor_db": 96.0},
    }
    base = ("deepeye680d_realistic", {"frequency_hz": 455000.0, "texture_db": 1.0})
    text = preset_toml(args, values, _NoStats(), _NoStats(), {"recording": "r"}, base)
    p = tmp_path / "sides.toml"
    p.write_text(text)
    pf = load_preset_file(p, per_side=True)
    assert pf.overrides == {"frequency_hz": 455000.0}  # the fitted texture_db is per side
    for side, v in values.items():
        cfg = pf.config(side)
        assert cfg.acoustic.realism.texture_db == v["texture_db"]
        assert cfg.acoustic.display_floor_db == v["display_floor_db"]
        assert cfg.frequency_hz == 455000.0
    with pytest.raises(ValueError, match="side = None"):
        pf.config()
    with pytest.raises(ValueError, match="one config for both sides"):
        load_preset_file(p)
    with pytest.raises(ScenarioError, match="per-side"):
        parse_scenario(_scenario_with(str(p)))
    p.write_text(text.replace("[sonar.overrides.starboard]", "[other]"))
    with pytest.raises(ValueError, match="need both"):
        load_preset_file(p, per_side=True)


@pytest.mark.parametrize(
    "text, message",
    [
        ("[sonar]\npreset = 'deepeye999'\n", "deepeye999"),
        ("[calibration]\nx = 1\n", "[sonar] preset"),
        ("[sonar]\npreset = 'deepeye680d'\n[sonar.overrides]\ntexture_db = 99.0\n", "texture_db"),
        ("[statistical_model]\ngain_db = 1.0\n", "statistical"),
        ("[sonar\n", "invalid TOML"),
    ],
)
def test_bad_preset_file_named_in_scenario_error(tmp_path, text, message):
    p = tmp_path / "bad.toml"
    p.write_text(text)
    with pytest.raises(ScenarioError) as ei:
        parse_scenario(_scenario_with(str(p)))
    assert "vehicles[0].sonars[0].preset" in str(ei.value) and message in str(ei.value)


def test_missing_file_and_unknown_name_are_named(tmp_path):
    with pytest.raises(ScenarioError, match="does not exist"):
        parse_scenario(_scenario_with(str(tmp_path / "nope.toml")))
    with pytest.raises(ScenarioError, match="deepeye680d"):
        parse_scenario(_scenario_with("no_such_preset"))


def test_shipped_calibrated_presets_load():
    shipped = calibrated_presets()
    for name in shipped:
        pf = load_preset_file(name)
        assert pf.base in ("deepeye680d_realistic", "deepeye680d")
        assert pf.config().acoustic.realism is not None


def test_scenario_sets_the_receiver_gain_over_a_shipped_preset():
    """A survey sets its own receiver gain over the calibrated preset's (the operator's
    setting for the recording's geometry); the file's other fields stay."""
    shipped = load_preset_file("scotsman_calibrated")
    spec = parse_scenario(
        _scenario_with("scotsman_calibrated", {"max_range": 40.0, "receiver_gain_db": 0.1})
    )
    rz = preset(spec.vehicles[0].sonars[0].preset, **dict(spec.vehicles[0].sonars[0].overrides))
    assert rz.acoustic.realism.receiver_gain_db == 0.1
    assert shipped.overrides["receiver_gain_db"] != 0.1
    assert rz.acoustic.realism.texture_db == shipped.overrides["texture_db"]


@pytest.mark.parametrize("gain", [150.0, "high"])
def test_bad_receiver_gain_override_is_named(gain):
    with pytest.raises(ScenarioError) as ei:
        parse_scenario(_scenario_with("scotsman_calibrated", {"receiver_gain_db": gain}))
    assert "vehicles[0].sonars[0].overrides" in str(ei.value)
    assert "receiver_gain_db" in str(ei.value)

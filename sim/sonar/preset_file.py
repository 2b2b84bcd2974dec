"""Sonar presets stored as TOML files: the calibrated presets that ``undersea calibrate``
writes (``assets/sonars/*.toml`` ship with the project), usable wherever a scenario names
a sonar preset:

```toml
[[vehicles.sonars]]
preset = "scotsman_calibrated"            # a file in assets/sonars/, by its stem
# preset = "path/to/my_sonar.toml"        # or any file (absolute, or relative to the cwd)
overrides = { max_range = 40.0 }          # applied over the file's own overrides
```

A preset file holds ``[sonar] preset = <built-in name>`` and ``[sonar.overrides]`` (flat
scalars, any field ``sim.sonar.config.preset`` takes); everything else (the
``[calibration]`` record) is ignored here. A per-side calibration (``undersea calibrate
--per-side``: one transducer and receive channel per side) adds ``[sonar.overrides.port]``
and ``[sonar.overrides.starboard]``, each side's values over the common ones
(``PresetFile.config(side=...)``). The simulator's side-scan takes one config for both
sides, so a scenario cannot use such a file yet: ``load_preset_file`` refuses it unless
``per_side=True``.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from sim.sonar.config import PRESETS, preset

SIDES = ("port", "starboard")
SONAR_ASSETS = Path(__file__).resolve().parents[2] / "assets" / "sonars"


@dataclass(frozen=True)
class PresetFile:
    """A preset file decoded: base (built-in preset name), overrides, source (the file),
    per-side overrides ({"port": {...}, "starboard": {...}} or empty)."""

    base: str
    overrides: dict[str, Any] = field(default_factory=dict)
    source: str = ""
    side_overrides: dict[str, dict[str, Any]] = field(default_factory=dict)

    def config(self, side: str | None = None, **more: Any) -> Any:
        """The sonar config: the base preset with the file's overrides, then ``side``'s
        own (a per-side file needs ``side``: "port" or "starboard"), then ``more``."""
        if self.side_overrides and side not in SIDES:
            raise ValueError(
                f"sonar preset file {self.source!r} has per-side overrides: side = {side!r}; "
                f"allowed: {', '.join(SIDES)}"
            )
        own = self.side_overrides.get(side, {}) if side else {}
        return preset(self.base, **{**self.overrides, **own, **more})


def calibrated_presets() -> dict[str, Path]:
    """Preset files shipped in ``assets/sonars``, by stem."""
    if not SONAR_ASSETS.is_dir():
        return {}
    return {p.stem: p for p in sorted(SONAR_ASSETS.glob("*.toml"))}


def is_preset_file(name: str) -> bool:
    """True when ``name`` names a preset file (a shipped stem or a ``.toml`` path)."""
    return name in calibrated_presets() or name.endswith(".toml")


def _scalars(table: Any, path: Path, where: str) -> dict[str, Any]:
    if not isinstance(table, dict) or any(isinstance(v, dict | list) for v in table.values()):
        raise ValueError(f"sonar preset file {str(path)!r}: [{where}] must be a table of scalars")
    return dict(table)


def load_preset_file(name_or_path: str | Path, per_side: bool = False) -> PresetFile:
    """Read a preset file by shipped stem or path; ValueError names the file and the field.
    ``per_side``: accept per-side overrides (``[sonar.overrides.port]`` / ``.starboard``;
    refused otherwise, since a scenario's side-scan takes one config for both sides)."""
    s = str(name_or_path)
    path = calibrated_presets().get(s, Path(s))
    if not path.is_file():
        shipped = ", ".join(calibrated_presets()) or "none"
        raise ValueError(
            f"sonar preset file {s!r} does not exist; allowed: a built-in preset "
            f"({', '.join(sorted(PRESETS))}), a shipped calibrated preset ({shipped}) or a "
            ".toml path"
        )
    try:
        with open(path, "rb") as f:
            doc = tomllib.load(f)
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ValueError(f"sonar preset file {str(path)!r}: invalid TOML ({exc})") from exc
    if "statistical_model" in doc and "sonar" not in doc:
        raise ValueError(
            f"sonar preset file {str(path)!r} was fitted with --model statistical: its "
            "values are not simulator fields; calibrate with --model raycast"
        )
    sonar = doc.get("sonar")
    if not isinstance(sonar, dict) or not isinstance(sonar.get("preset"), str):
        raise ValueError(f"sonar preset file {str(path)!r}: needs [sonar] preset = <built-in name>")
    base = sonar["preset"]
    if base not in PRESETS:
        raise ValueError(
            f"sonar preset file {str(path)!r}: sonar.preset = {base!r} is not a built-in "
            f"preset; allowed: {', '.join(sorted(PRESETS))}"
        )
    ov = sonar.get("overrides", {})
    if not isinstance(ov, dict):
        raise ValueError(f"sonar preset file {str(path)!r}: [sonar.overrides] must be a table")
    sides = {s: _scalars(ov[s], path, f"sonar.overrides.{s}") for s in SIDES if s in ov}
    if sides and set(sides) != set(SIDES):
        raise ValueError(
            f"sonar preset file {str(path)!r}: per-side overrides need both "
            "[sonar.overrides.port] and [sonar.overrides.starboard]"
        )
    if sides and not per_side:
        raise ValueError(
            f"sonar preset file {str(path)!r} has per-side overrides ([sonar.overrides.port], "
            "[sonar.overrides.starboard]): the simulator's side-scan takes one config for "
            "both sides, so a scenario cannot use it yet"
        )
    common = _scalars({k: v for k, v in ov.items() if k not in SIDES}, path, "sonar.overrides")
    pf = PresetFile(base=base, overrides=common, source=str(path), side_overrides=sides)
    for side in (*SIDES,) if sides else (None,):
        where = f"sonar.overrides.{side}" if side else "sonar.overrides"
        try:
            pf.config(side)
        except (ValueError, TypeError) as exc:
            raise ValueError(f"sonar preset file {str(path)!r}: [{where}]: {exc}") from exc
    return pf

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
``[calibration]`` record) is ignored here.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from sim.sonar.config import PRESETS, preset

SONAR_ASSETS = Path(__file__).resolve().parents[2] / "assets" / "sonars"


@dataclass(frozen=True)
class PresetFile:
    """A preset file decoded: base (built-in preset name), overrides, source (the file)."""

    base: str
    overrides: dict[str, Any] = field(default_factory=dict)
    source: str = ""

    def config(self, **more: Any) -> Any:
        """The sonar config: the base preset with the file's overrides, then ``more``."""
        return preset(self.base, **{**self.overrides, **more})


def calibrated_presets() -> dict[str, Path]:
    """Preset files shipped in ``assets/sonars``, by stem."""
    if not SONAR_ASSETS.is_dir():
        return {}
    return {p.stem: p for p in sorted(SONAR_ASSETS.glob("*.toml"))}


def is_preset_file(name: str) -> bool:
    """True when ``name`` names a preset file (a shipped stem or a ``.toml`` path)."""
    return name in calibrated_presets() or name.endswith(".toml")


def load_preset_file(name_or_path: str | Path) -> PresetFile:
    """Read a preset file by shipped stem or path; ValueError names the file and the field."""
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
    if not isinstance(ov, dict) or any(isinstance(v, dict | list) for v in ov.values()):
        raise ValueError(
            f"sonar preset file {str(path)!r}: [sonar.overrides] must be a table of scalars"
        )
    pf = PresetFile(base=base, overrides=dict(ov), source=str(path))
    try:
        pf.config()
    except (ValueError, TypeError) as exc:
        raise ValueError(f"sonar preset file {str(path)!r}: [sonar.overrides]: {exc}") from exc
    return pf

"""The receiver gain of shipwreck-survey for a calibrated side-scan preset, by the rule of
docs/sonar_realism.md ("The receiver gain set for the survey"): the gain at which the
first leg clips the same fraction of each side as the recording pings the preset was
fitted on, solved as ``undersea calibrate`` solves it (sim.realism.survey.GainProfiledSurvey:
per side, full scale over the side's (1 − t) quantile of the unclipped intensity; the two
sides' gains averaged in dB).

    .venv/bin/python scripts/shipwreck_gain_rule.py PRESET.toml [--seed 1] [--seconds 20]

The capture: the scenario's side-scan with ``preset = PRESET``, ``max_range = 40``, gain
0 dB, ADC and log compression off, over the first ``--seconds`` s. Targets: the Scotsman
fit half's clipped fractions (pings 0–229, port 1.33 %, starboard 1.91 %).
"""

from __future__ import annotations

import argparse

import numpy as np

from sim.runner.schedule import ScenarioRun
from sim.scenario.schema import load_scenario_dict, parse_scenario
from sim.sonar.preset_file import load_preset_file

TARGET = (0.013277, 0.019115)  # Scotsman pings 0-229, port / starboard clipped fraction


def capture(preset: str, seed: int, seconds: float) -> np.ndarray:
    """(pings, 2S) unclipped linear intensity of shipwreck-survey's side-scan, port left."""
    d = load_scenario_dict("shipwreck-survey")
    d["seed"] = seed
    d["duration_s"] = seconds
    d.setdefault("outputs", {}).update(recording=False, figures=False)
    sonar = d["vehicles"][0]["sonars"][0]
    sonar["preset"] = preset
    sonar["overrides"] = dict(
        max_range=40.0, receiver_gain_db=0.0, bit_depth=0, log_compression=False
    )
    run = ScenarioRun(parse_scenario(d), [])
    pings: list[np.ndarray] = []
    for s in (s for v in run.vehicles for s in v.sonars if s.kind == "sss"):
        fire = s.sonar.ping

        def kept(data, rng, _fire=fire):
            p = _fire(data, rng)
            pings.append(np.asarray(p.intensity, dtype=np.float64).ravel())
            return p

        s.sonar.ping = kept
    run.run(seconds)
    return np.array(pings)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("preset", help="calibrated preset file (.toml) or shipped stem")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--seconds", type=float, default=20.0)
    a = ap.parse_args()
    fs_db = load_preset_file(a.preset).config().acoustic.realism.full_scale_db
    img = capture(a.preset, a.seed, a.seconds)
    s = img.shape[1] // 2
    sides = (img[:, :s], img[:, s:])
    gains = [fs_db - 10.0 * np.log10(np.quantile(x, 1.0 - t)) for x, t in zip(sides, TARGET)]
    g = float(np.mean(gains))
    fs = 10.0 ** ((fs_db - g) / 10.0)
    clipped = [100.0 * float(np.mean(x >= fs)) for x in sides]
    print(f"{img.shape[0]} pings; gain port {gains[0]:.2f} dB, starboard {gains[1]:.2f} dB")
    print(f"receiver_gain_db = {g:.2f} (clips {clipped[0]:.2f} / {clipped[1]:.2f} %)")


if __name__ == "__main__":
    main()

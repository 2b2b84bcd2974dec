"""What a sweep run executes, by target name.

* ``slam:<experiment>`` — one Monte Carlo run of a reference SLAM experiment
  (``dense-loop``, ``line``, ``segmentation-loop``; see ``undersea slam-experiment``).
  Parameters: ``filter`` (aekf, fastslam2, isam2), ``dt`` (s), ``loops``; any key
  ``est.<name>`` is passed to the estimator (e.g. ``est.reject_gate=4.0``).
* anything else — a scenario (built-in name or TOML path) run headless by the scenario
  runner; parameters are dotted overrides of the scenario file
  (``slam.estimator=fastslam2``, ``world.seed=3``).

A task is ``task(params: dict, seed: int, artifacts: Path) -> dict`` of JSON metrics; the
sweep's NEES consistency reads the per-step pose NEES from the ``nees_series`` key.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import numpy as np

Task = Callable[[dict, int, Path], dict]


def _finite_or_none(x):
    return float(x) if x is not None and math.isfinite(float(x)) else None


def slam_task(experiment: str) -> Task:
    from slam.experiments import get_experiment

    # validate the name now, not in every worker
    get_experiment(experiment)

    def run(params: dict, seed: int, artifacts: Path) -> dict:
        from slam.experiments import get_experiment, run_once

        params = dict(params)
        filter_name = str(params.pop("filter", "aekf"))
        dt = float(params.pop("dt", 0.025))
        loops = params.pop("loops", None)
        est = {k.removeprefix("est."): v for k, v in params.items() if k.startswith("est.")}
        unknown = [k for k in params if not k.startswith("est.")]
        if unknown:
            raise ValueError(
                f"unknown slam sweep parameter(s) {unknown}; allowed: filter, dt, loops, est.<name>"
            )
        spec = get_experiment(experiment, dt=dt, n_loops=None if loops is None else int(loops))
        result = run_once(spec, filter_name, seed, est or None)
        metrics = result.summary()
        metrics.pop("seed", None)
        metrics.pop("filter", None)
        metrics["nees_series"] = [_finite_or_none(v) for v in np.asarray(result.nees, float)]
        return metrics

    return run


def scenario_task(scenario: str) -> Task:
    from sim.scenario import load_scenario_dict

    load_scenario_dict(scenario)  # fail fast on an unknown scenario

    def run(params: dict, seed: int, artifacts: Path) -> dict:
        from sim.runner import run_scenario
        from sim.scenario import load_scenario

        # the overrides go through the scenario validation: a bad key or value fails here,
        # with the scenario's own message, and is recorded as this run's error
        spec = load_scenario(scenario, overrides=params).with_overrides(seed=seed)
        result = run_scenario(spec, artifacts, overwrite=True, progress=False)
        if not result.complete:
            raise RuntimeError(f"scenario run incomplete: {artifacts}")
        metrics = dict(result.metrics)
        metrics.pop("objects", None)  # world description, not a metric
        return metrics

    return run


def resolve_task(target: str) -> Task:
    """The task for a sweep target; raises ValueError naming the allowed forms."""
    if target.startswith("slam:"):
        return slam_task(target.removeprefix("slam:"))
    try:
        return scenario_task(target)
    except (FileNotFoundError, KeyError, ValueError) as exc:
        raise ValueError(
            f"unknown sweep target {target!r} ({exc}); allowed: a scenario name "
            "(see `undersea scenarios`), a scenario .toml path, or "
            "slam:dense-loop | slam:line | slam:segmentation-loop"
        ) from exc


def target_content(target: str):
    """What a sweep's plan hash covers besides the target's name: the decoded scenario
    file of a scenario target (editing the file changes the plan), None for slam:*."""
    if target.startswith("slam:"):
        return None
    from sim.scenario import load_scenario_dict

    return load_scenario_dict(target)


def validate_variant(target: str, params: dict) -> None:
    """Raise ValueError naming the bad key or value of one variant, before any run."""
    if target.startswith("slam:"):
        unknown = [k for k in params if k not in ("filter", "dt", "loops") and not k.startswith("est.")]
        if unknown:
            raise ValueError(
                f"--vary {unknown[0]!r}: unknown parameter of {target}; "
                "allowed: filter, dt, loops, est.<name>"
            )
        return
    from sim.scenario import ScenarioError, load_scenario

    try:
        load_scenario(target, overrides=params)
    except ScenarioError as exc:
        raise ValueError(f"--vary {', '.join(f'{k}={v}' for k, v in params.items())}: {exc}") from exc

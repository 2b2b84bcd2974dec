"""Gymnasium env speed: steps/s of each undersea env, single and vectorized.

Cases, measured one after the other in one run, random actions, resets included:
  WaypointNav-v0             — nav-sensor suite on (default) and off (ideal navigation);
  SonarSurvey-v0             — one side-scan ping every step (fast SSS, 2 x 128 samples);
  ActiveSLAM-v0              — ping every step + windowed segmentation + lagged AEKF;
  WaypointNav-v0 x N async   — ``gymnasium.make_vec(..., vectorization_mode="async")``
                               (total steps/s over the N sub-environments).
Targets (issue 6, this machine): WaypointNav >= 2,000 steps/s on one core; SonarSurvey
with a sonar frame every step >= 200 steps/s. Wrappers are the registered ones
(TimeLimit, OrderEnforcing, PassiveEnvChecker) as a user gets from ``gymnasium.make``.

    undersea bench env [--json] [--steps N] [--vec N]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time

TARGETS = {"WaypointNav-v0": 2000.0, "SonarSurvey-v0": 200.0}


def _single(env_id: str, steps: int, **kw) -> float:
    import gymnasium as gym

    env = gym.make(env_id, **kw)
    env.reset(seed=0)
    env.action_space.seed(0)
    acts = [env.action_space.sample() for _ in range(min(steps, 1000))]
    for a in acts[:20]:  # warm-up
        _, _, te, tr, _ = env.step(a)
        if te or tr:
            env.reset()
    t0 = time.perf_counter()
    for k in range(steps):
        _, _, te, tr, _ = env.step(acts[k % len(acts)])
        if te or tr:
            env.reset()
    dt = time.perf_counter() - t0
    env.close()
    return steps / dt


def _vector(env_id: str, n: int, steps: int, **kw) -> float:
    import gymnasium as gym

    venv = gym.make_vec(env_id, num_envs=n, vectorization_mode="async", **kw)
    venv.reset(seed=list(range(n)))
    venv.action_space.seed(0)
    for _ in range(10):
        venv.step(venv.action_space.sample())
    t0 = time.perf_counter()
    for _ in range(steps):
        venv.step(venv.action_space.sample())
    dt = time.perf_counter() - t0
    venv.close()
    return n * steps / dt


def main(argv: list[str] | None = None) -> int:
    import sim.envs  # noqa: F401

    p = argparse.ArgumentParser(prog="undersea bench env", description=__doc__.splitlines()[0])
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument(
        "--steps", type=int, default=2000, help="steps per WaypointNav case (sonar envs: /5)"
    )
    p.add_argument("--vec", type=int, default=2, help="sub-environments for the async case")
    a = p.parse_args(argv)
    n = a.steps
    res = {
        "WaypointNav-v0": _single("undersea/WaypointNav-v0", n),
        "WaypointNav-v0 ideal-nav": _single("undersea/WaypointNav-v0", n, nav_sensors=False),
        "SonarSurvey-v0": _single("undersea/SonarSurvey-v0", max(50, n // 5)),
        "SonarSurvey-v0 ideal-nav": _single(
            "undersea/SonarSurvey-v0", max(50, n // 5), nav_sensors=False
        ),
        "ActiveSLAM-v0": _single("undersea/ActiveSLAM-v0", max(50, n // 5)),
        f"WaypointNav-v0 x{a.vec} async": _vector(
            "undersea/WaypointNav-v0", a.vec, max(50, n // a.vec)
        ),
        f"SonarSurvey-v0 x{a.vec} async": _vector(
            "undersea/SonarSurvey-v0", a.vec, max(20, n // (5 * a.vec))
        ),
    }
    out = {
        "steps_per_s": {k: round(v, 1) for k, v in res.items()},
        "targets_steps_per_s": TARGETS,
        "meets_target": {k: res[k] >= t for k, t in TARGETS.items()},
        "machine": {
            "cpus": os.cpu_count(),
            "python": platform.python_version(),
            "load_avg_1min": os.getloadavg()[0],
        },
    }
    if a.json:
        print(json.dumps(out))
    else:
        print(f"env steps/s ({os.cpu_count()} CPUs, load {os.getloadavg()[0]:.2f}):")
        for k, v in res.items():
            tgt = TARGETS.get(k)
            mark = "" if tgt is None else f"   target >= {tgt:.0f}: {'yes' if v >= tgt else 'NO'}"
            print(f"  {k:<32} {v:10.1f}{mark}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

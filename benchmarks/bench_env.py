"""Gymnasium env speed: steps/s of each undersea env, single and vectorized.

Cases, measured one after the other in one run, random actions, resets included:
  WaypointNav-v0             — nav-sensor suite on (default) and off (ideal navigation);
  SonarSurvey-v0             — one side-scan ping every step (fast SSS, 2 x 128 samples);
  ActiveSLAM-v0              — ping every step + windowed segmentation + lagged AEKF;
  WaypointNav-v0 x N async   — ``gymnasium.make_vec(..., vectorization_mode="async")``
                               (total steps/s over the N sub-environments);
  WaypointNav-v0 x B batch   — ``vectorization_mode="vector_entry_point"``
                               (sim.envs.vector_nav, B vehicles in one model), nav
                               sensors on and ideal navigation; its RSS after the
                               warm-up and after ``--growth-steps`` more env steps;
  SonarSurvey-v0 x S batch   — the same for sim.envs.vector_sonar (S vehicles, one
                               ping each per step), nav sensors on; RSS over
                               ``--sonar-growth-steps`` more env steps;
  bare mj_step               — the WaypointNav model's own ``mj_step`` rate, per action
                               (``frame_skip`` physics steps), the floor of the env.
Targets (issue 6, this machine): WaypointNav >= 2,000 steps/s on one core; SonarSurvey
with a sonar frame every step >= 200 steps/s. Issue 16 (ratios in one run): batch at
64 >= 20x the single env of the same navigation mode; RSS < 2 GB at 64, no growth (both
navigation modes); with ``--against TREE`` (another checkout, e.g. main) the single
WaypointNav env of this tree >= 3x that tree's, measured in turn in this run (the other
tree's in a subprocess with its own code).
Single, batch and bare figures are CPU time of this thread; async is wall time.
Wrappers are the registered ones (TimeLimit, OrderEnforcing, PassiveEnvChecker) as a
user gets from ``gymnasium.make``.

    undersea bench env [--json] [--steps N] [--vec N] [--batch B] [--growth-steps S]
                       [--against TREE]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:  # loaded by file path (undersea bench): the checkout's root
    sys.path.insert(0, str(REPO))

from benchmarks.other_tree import json_from_tree  # noqa: E402

TARGETS = {"WaypointNav-v0": 2000.0, "SonarSurvey-v0": 200.0}
BATCH_GOAL = 20.0  # batch aggregate steps/s over the single env's, same navigation mode
SINGLE_GOAL = 3.0  # single WaypointNav steps/s over the --against tree's
RSS_GOAL_MB = 2048.0


def _clock() -> float:
    """CPU time of this thread: the in-process cases are single-threaded, and on a shared
    machine their CPU time is steadier than the wall clock (the async case, whose work is
    in other processes, is timed by the wall clock)."""
    return time.thread_time()


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
    t0 = _clock()
    for k in range(steps):
        _, _, te, tr, _ = env.step(acts[k % len(acts)])
        if te or tr:
            env.reset()
    dt = _clock() - t0
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


def _single_in(tree: str, steps: int, **kw) -> float:
    """``_single`` of WaypointNav-v0 run by another checkout's own code (a subprocess with
    that tree first on the path)."""
    code = (
        "import json, sys; import sim.envs; from benchmarks.bench_env import _single; "
        f"print(json.dumps(_single('undersea/WaypointNav-v0', {steps}, **{kw!r})))"
    )
    return float(json_from_tree(tree, code, "WaypointNav run"))


def _rss_mb() -> float:
    import psutil

    return psutil.Process().memory_info().rss / 2**20


def _batch(n: int, steps: int, growth_steps: int, env_id="undersea/WaypointNav-v0", **kw) -> dict:
    """Aggregate steps/s of the batched env; RSS after the warm-up and after
    ``growth_steps`` more env steps (all sub-envs counted)."""
    import gymnasium as gym
    import numpy as np

    venv = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", **kw)
    venv.reset(seed=0)
    rng = np.random.default_rng(0)
    acts = rng.uniform(-1, 1, (64, *venv.action_space.shape)).astype(np.float32)
    for k in range(10):
        venv.step(acts[k])
    rss0 = _rss_mb()
    t0 = _clock()
    for k in range(steps):
        venv.step(acts[k % 64])
    rate = n * steps / (_clock() - t0)
    for k in range(max(0, growth_steps // n - steps)):
        venv.step(acts[k % 64])
    out = {"steps_per_s": rate, "rss_mb_start": rss0, "rss_mb_end": _rss_mb()}
    out["env_steps_between_rss"] = max(growth_steps, n * steps)
    venv.close()
    return out


def _bare_rate() -> float:
    """Actions/s the WaypointNav model's bare mj_step allows (frame_skip steps each)."""
    import gymnasium as gym
    import mujoco

    env = gym.make("undersea/WaypointNav-v0").unwrapped
    env.reset(seed=0)
    m, d = env.world.model, env.world.data
    m.opt.gravity[:] = 0.0  # stays in mid-water like the env's vehicle
    n = 20000
    t0 = _clock()
    mujoco.mj_step(m, d, nstep=n)
    return n / env.frame_skip / (_clock() - t0)


def main(argv: list[str] | None = None) -> int:
    import sim.envs  # noqa: F401

    p = argparse.ArgumentParser(prog="undersea bench env", description=__doc__.splitlines()[0])
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument(
        "--steps", type=int, default=2000, help="steps per WaypointNav case (sonar envs: /5)"
    )
    p.add_argument("--vec", type=int, default=2, help="sub-environments for the async case")
    p.add_argument("--batch", type=int, default=64, help="vehicles of the batched env")
    p.add_argument(
        "--growth-steps", type=int, default=100_000, help="env steps between the RSS readings"
    )
    p.add_argument("--sonar-batch", type=int, default=64, help="vehicles of the SonarSurvey batch")
    p.add_argument(
        "--sonar-growth-steps",
        type=int,
        default=10_000,
        help="SonarSurvey batch: env steps between the RSS readings",
    )
    p.add_argument(
        "--against",
        metavar="TREE",
        help="another checkout (e.g. main): its single WaypointNav env, measured in this run",
    )
    a = p.parse_args(argv)
    if a.against is not None and not os.path.isdir(os.path.join(a.against, "sim", "envs")):
        print(
            f"--against {a.against!r}: not a checkout of this project (no sim/envs)",
            file=sys.stderr,
        )
        return 2
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
    b = a.batch
    batch = {
        "ideal-nav": _batch(b, max(20, n // b * 4), a.growth_steps, nav_sensors=False),
        "nav-sensors": _batch(b, max(20, n // b * 4), a.growth_steps),
    }
    sb = a.sonar_batch
    batch["sonar"] = _batch(
        sb, max(5, n // (sb * 2)), a.sonar_growth_steps, env_id="undersea/SonarSurvey-v0"
    )
    res[f"SonarSurvey-v0 x{sb} batch"] = batch["sonar"]["steps_per_s"]
    res[f"WaypointNav-v0 x{b} batch"] = batch["nav-sensors"]["steps_per_s"]
    res[f"WaypointNav-v0 x{b} batch ideal-nav"] = batch["ideal-nav"]["steps_per_s"]
    res["bare mj_step (actions/s)"] = _bare_rate()
    ratios = {
        f"x{b} batch / single": res[f"WaypointNav-v0 x{b} batch"] / res["WaypointNav-v0"],
        f"x{b} batch ideal-nav / single ideal-nav": res[f"WaypointNav-v0 x{b} batch ideal-nav"]
        / res["WaypointNav-v0 ideal-nav"],
        "bare mj_step / single": res["bare mj_step (actions/s)"] / res["WaypointNav-v0"],
        f"SonarSurvey x{sb} batch / single": res[f"SonarSurvey-v0 x{sb} batch"]
        / res["SonarSurvey-v0"],
    }
    if a.against is not None:  # the other tree's single env, right after this tree's
        res["WaypointNav-v0 (--against)"] = _single_in(a.against, n)
        res["WaypointNav-v0 ideal-nav (--against)"] = _single_in(a.against, n, nav_sensors=False)
        ratios["single / --against single"] = (
            res["WaypointNav-v0"] / res["WaypointNav-v0 (--against)"]
        )
        ratios["single ideal-nav / --against single ideal-nav"] = (
            res["WaypointNav-v0 ideal-nav"] / res["WaypointNav-v0 ideal-nav (--against)"]
        )
    rss = batch["ideal-nav"]
    out = {
        "ratios": ratios,
        "batch_goal": BATCH_GOAL,
        "rss_mb": rss,
        "rss_mb_nav_sensors": batch["nav-sensors"],
        "rss_mb_sonar": batch["sonar"],
        "single_goal_vs_against": SINGLE_GOAL,
        "rss_goal_mb": RSS_GOAL_MB,
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
            print(f"  {k:<40} {v:10.1f}{mark}")
        for k, v in ratios.items():
            g = BATCH_GOAL if "batch" in k else SINGLE_GOAL if k.startswith("single /") else None
            goal = "" if g is None else f"   goal >= {g:g}x: {'yes' if v >= g else 'NO'}"
            print(f"  ratio {k:<44} {v:8.2f}x{goal}")
        print(
            f"  batch x{b} RSS {rss['rss_mb_start']:.0f} MB after warm-up, "
            f"{rss['rss_mb_end']:.0f} MB after {rss['env_steps_between_rss']} more env steps "
            f"(goal < {RSS_GOAL_MB:.0f} MB, no growth)"
        )
        r2 = batch["nav-sensors"]
        print(
            f"  batch x{b} nav sensors RSS {r2['rss_mb_start']:.0f} MB after warm-up, "
            f"{r2['rss_mb_end']:.0f} MB after {r2['env_steps_between_rss']} more env steps"
        )
        r3 = batch["sonar"]
        print(
            f"  SonarSurvey batch x{sb} RSS {r3['rss_mb_start']:.0f} MB after warm-up, "
            f"{r3['rss_mb_end']:.0f} MB after {r3['env_steps_between_rss']} more env steps"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Physics speed: steps/s and real-time factor at the default timestep.

Cases (measured side by side in one run):
  one       — Alister 9 alone, full hydrodynamics (buoyancy, added mass, damping,
              thrusters with lag, fins) over the default 100 m × 100 m rippled seabed
              with seabed contacts;
  swarms4   — Alister 9, IXN, Naiad and SAGA in one world (one vectorized pass);
  current   — the four vehicles in a seeded spatially/temporally varying current;
Each case is paired with the bare ``mj_step`` of ITS OWN model (no hydrodynamics, the
floor), measured right after it in the same run; the ratio of the two CPU costs per step
is printed beside its goal.
Targets: issue 2, one ≥ 100× real time, swarms4 ≥ 25× real time; issue 16, µs per step
≤ 3× the bare mj_step of the same model (one, swarms4).

    undersea bench physics [--json] [--seconds S] [--timestep DT]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time

import mujoco
import numpy as np

from sim.world import CurrentSpec, SeabedSpec, VehicleSpec, WorldSpec, build_world

TARGETS = {"one": 100.0, "swarms4": 25.0}
RATIO_GOALS = {"one": 3.0, "swarms4": 3.0}  # cost per step / bare mj_step of the same model


def _world(kinds, dt, current=None):
    vs = tuple(VehicleSpec(k, position=(-30.0 + 15.0 * i, 0.0, -10.0)) for i, k in enumerate(kinds))
    return build_world(
        WorldSpec(
            seabed=SeabedSpec(kind="ripples", seed=1),
            vehicles=vs,
            timestep=dt,
            current=current or CurrentSpec(),
        )
    )


def _run(world, sim_seconds: float, rng: np.random.Generator) -> tuple[list[float], float]:
    """Wall times of successive 1-s chunks of simulation, commands changing every 0.1 s
    (a control rate) as a controller would."""
    n = max(1, round(0.1 / world.timestep))
    chunks = int(sim_seconds / 0.1)
    handles = list(world.vehicles.values())
    cmds = [rng.uniform(-0.6, 0.6, (chunks, h.n_thrusters)) for h in handles]
    for h, c in zip(handles, cmds):  # mostly forward for the torpedo so fins see flow
        if h.kind == "alister9":
            c[:, 0] = np.abs(c[:, 0]) + 0.3
    walls = []
    c0 = time.thread_time()
    t0 = time.perf_counter()
    for k in range(chunks):
        for h, c in zip(handles, cmds):
            h.set_thruster_commands(c[k])
        world.step(n)
        if k % 10 == 9:
            t1 = time.perf_counter()
            walls.append(t1 - t0)
            t0 = t1
    return walls, time.thread_time() - c0


def _bare(world, sim_seconds: float) -> float:
    """CPU µs per bare ``mj_step`` of the world's model: no hydrodynamics and no gravity,
    so the vehicles stay in mid-water as in the hydrodynamic case (what MuJoCo alone
    costs for the same bodies and the same contacts: none)."""
    m, d = world.model, world.data
    m.opt.gravity[:] = 0.0
    n = int(sim_seconds / world.timestep)
    mujoco.mj_step(m, d, nstep=100)  # warm-up
    c0 = time.thread_time()
    mujoco.mj_step(m, d, nstep=n)
    return (time.thread_time() - c0) / n * 1e6


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="undersea bench physics", description=__doc__.split("\n")[0])
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    ap.add_argument("--seconds", type=float, default=30.0, help="simulated seconds per case")
    ap.add_argument(
        "--timestep", type=float, default=WorldSpec().timestep, help="physics timestep, s"
    )
    a = ap.parse_args(argv)
    dt = a.timestep
    rng = np.random.default_rng(0)
    out: dict = {
        "timestep_s": dt,
        "simulated_s": a.seconds,
        "machine": platform.machine(),
        "mujoco": mujoco.__version__,
        "load_average_1min": os.getloadavg()[0],
        "cpu_count": os.cpu_count(),
        "cases": {},
    }
    cases = {
        "one": (("alister9",), None),
        "swarms4": (("alister9", "ixn", "naiad", "saga"), None),
        "current": (
            ("alister9", "ixn", "naiad", "saga"),
            CurrentSpec(velocity=(0.2, 0.1, 0.0), variation=0.1, seed=2),
        ),
    }
    for name, (kinds, cur) in cases.items():
        w = _world(kinds, dt, cur)
        _run(w, 1.0, rng)  # warm-up
        walls, cpu = _run(w, a.seconds, rng)  # wall time per simulated second, CPU total
        walls = np.array(walls)
        out["cases"][name] = {
            "vehicles": len(kinds),
            "steps_per_s": 1.0 / dt / float(np.mean(walls)),
            "real_time_factor": 1.0 / float(np.mean(walls)),
            "real_time_factor_best_second": 1.0 / float(walls.min()),
            "us_per_step": float(np.mean(walls)) * dt * 1e6,
            # thread CPU time: what the step costs when the machine is not shared
            "real_time_factor_cpu": len(walls) / cpu,
            "cpu_us_per_step": cpu / (len(walls) / dt) * 1e6,
        }
    for name, (kinds, cur) in cases.items():  # the floor of each case: its bare mj_step
        out["cases"][name]["bare_mj_step_cpu_us"] = _bare(_world(kinds, dt, cur), a.seconds)
        out["cases"][name]["cpu_cost_vs_bare_mj_step"] = (
            out["cases"][name]["cpu_us_per_step"] / out["cases"][name]["bare_mj_step_cpu_us"]
        )
    w = _world(("alister9",), dt)
    m, d = w.model, w.data
    n = int(a.seconds / dt)
    c0 = time.thread_time()
    t0 = time.perf_counter()
    mujoco.mj_step(m, d, nstep=n)
    wall = time.perf_counter() - t0
    cpu = time.thread_time() - c0
    out["cases"]["mujoco"] = {
        "vehicles": 1,
        "steps_per_s": n / wall,
        "real_time_factor": n * dt / wall,
        "real_time_factor_best_second": n * dt / wall,
        "us_per_step": wall / n * 1e6,
        "real_time_factor_cpu": n * dt / cpu,
        "cpu_us_per_step": cpu / n * 1e6,
    }
    out["ratio_goals"] = RATIO_GOALS
    out["meets_ratio_goals"] = {
        k: out["cases"][k]["cpu_cost_vs_bare_mj_step"] <= v for k, v in RATIO_GOALS.items()
    }
    out["targets_real_time_factor"] = TARGETS
    out["meets_targets"] = {k: out["cases"][k]["real_time_factor"] >= v for k, v in TARGETS.items()}
    out["meets_targets_cpu_time"] = {
        k: out["cases"][k]["real_time_factor_cpu"] >= v for k, v in TARGETS.items()
    }
    if a.json:
        print(json.dumps(out))
    else:
        print(
            f"physics timestep {dt} s, {a.seconds:g} simulated s per case; "
            f"load average {out['load_average_1min']:.1f} on {out['cpu_count']} CPUs"
        )
        for k, c in out["cases"].items():
            tgt = f"  target {TARGETS[k]:g}x" if k in TARGETS else ""
            print(
                f"  {k:8s} {c['vehicles']} vehicle(s): {c['steps_per_s']:9.0f} steps/s  "
                f"{c['real_time_factor']:7.1f}x real time (best second "
                f"{c['real_time_factor_best_second']:7.1f}x; CPU time "
                f"{c['real_time_factor_cpu']:7.1f}x)  {c['us_per_step']:6.1f} us/step{tgt}"
            )
        print("  CPU cost per step vs the bare mj_step of the same model (same run):")
        for k in cases:
            c = out["cases"][k]
            goal = RATIO_GOALS.get(k)
            mark = (
                ""
                if goal is None
                else f"   goal <= {goal:g}x: {'yes' if c['cpu_cost_vs_bare_mj_step'] <= goal else 'NO'}"
            )
            print(
                f"  {k:8s} {c['cpu_us_per_step']:7.2f} us vs bare {c['bare_mj_step_cpu_us']:6.2f} us"
                f" = {c['cpu_cost_vs_bare_mj_step']:5.2f}x{mark}"
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

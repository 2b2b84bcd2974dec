"""Physics speed: steps/s and real-time factor at the default timestep.

Cases (measured side by side in one run):
  one       — Alister 9 alone, full hydrodynamics (buoyancy, added mass, damping,
              thrusters with lag, fins) over the default 100 m × 100 m rippled seabed
              with seabed contacts;
  swarms4   — Alister 9, IXN, Naiad and SAGA in one world (one vectorized pass);
  current   — the four vehicles in a seeded spatially/temporally varying current;
  mujoco    — the bare ``mj_step`` of the one-vehicle model (no hydrodynamics) as the floor.
Targets (issue 2): one ≥ 100× real time, swarms4 ≥ 25× real time.

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
    for k in ("one", "swarms4", "current"):  # side-by-side ratio to the bare MuJoCo step
        out["cases"][k]["cpu_cost_vs_bare_mj_step"] = (
            out["cases"][k]["cpu_us_per_step"] / out["cases"]["mujoco"]["cpu_us_per_step"]
        )
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
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Simulate a straight side-scan leg over a scenario's world and save the waterfall as
linear intensity after TVG (``.npy``, the input of ``undersea realism``).

    PYTHONPATH=. python scripts/sss_realism_waterfall.py shipwreck-survey /tmp/sim.npy \
        --preset deepeye680d_realistic --pings 460 --altitude 8

The vehicle is moved kinematically along +x at the mission speed, at a constant depth
chosen so that its altitude above the world centre is ``--altitude`` (the seabed relief
then makes the altitude, hence the nadir, wander). Real recordings are compared on the
first lawnmower leg; this leg runs along y = ``--y``.
"""

from __future__ import annotations

import argparse

import mujoco
import numpy as np

from sim.runner.build import world_spec_from_scenario
from sim.scenario.schema import load_scenario
from sim.sonar import SideScanSonar, preset
from sim.world import build_world


class _Water:
    def __init__(self, w):
        self.temperature_c, self.salinity_psu = w.temperature_c, w.salinity_psu
        self.sound_speed, self.depth = w.sound_speed, float(w.surface_z)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scenario")
    ap.add_argument("out")
    ap.add_argument("--preset", default="deepeye680d_realistic")
    ap.add_argument("--pings", type=int, default=460)
    ap.add_argument("--altitude", type=float, default=8.0)
    ap.add_argument("--speed", type=float, default=1.5)
    ap.add_argument("--x0", type=float, default=-40.0)
    ap.add_argument("--y", type=float, default=-30.0)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--max-range", type=float, default=40.0)
    ap.add_argument("--set", nargs="*", default=[], help="preset overrides key=value")
    a = ap.parse_args()
    scn = load_scenario(a.scenario)
    world = build_world(world_spec_from_scenario(scn))
    name = scn.vehicles[0].name
    h = world.vehicles[name]
    over = {k: float(v) for k, v in (kv.split("=", 1) for kv in a.set)}
    cfg = preset(a.preset, max_range=a.max_range, log_compression=False, **over)
    m, d = world.model, world.data
    son = SideScanSonar(
        cfg,
        m,
        d,
        (h.site_ids["sss_port"], h.site_ids["sss_starboard"]),
        world.geom_object_id,
        world.geom_reflectivity,
        _Water(world.water),
        static_mesh=world.static_mesh(),
    )
    q = m.jnt_qposadr[m.body_jntadr[h.body_id]]
    z0 = float(world.seabed_height(np.array([[a.x0, a.y]]))[0]) + a.altitude
    rng = np.random.default_rng(a.seed)
    step = a.speed / cfg.ping_rate_hz
    rows, alt = [], []
    for k in range(a.pings):
        d.qpos[q : q + 3] = (a.x0 + k * step, a.y, z0)
        d.qpos[q + 3 : q + 7] = (1.0, 0.0, 0.0, 0.0)
        mujoco.mj_forward(m, d)
        p = son.ping(d, rng)
        rows.append(p.intensity)
        alt.append(p.altitude)
    np.save(a.out, np.stack(rows))
    alt = np.array(alt)
    print(f"{a.out}: {len(rows)} pings; altitude {np.nanmin(alt):.2f}–{np.nanmax(alt):.2f} m")


if __name__ == "__main__":
    main()

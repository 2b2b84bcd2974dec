"""Fly straight legs past shipwreck-survey's objects with a scenario's side-scan, save
each leg's waterfall and run the scenario's side-scan front end on it; with
``--contrast`` print each imaged object's highlight over the local seabed, its clipped
fraction and its shadow (docs/detections.md, "Small objects on the calibrated preset").

    PYTHONPATH=. python scripts/small_object_legs.py my_survey.toml /tmp/leg --seed 12 \
        --set '{"bit_depth": 0}' --contrast

Legs (260 pings, 8 m altitude, the mission speed) run along the survey's lines y = -30
(A, eastbound), 0 (B, westbound) and 30 (C, eastbound), centred on an object's x. The
vehicle is placed kinematically (no dynamics, no navigation error).
"""

from __future__ import annotations

import argparse
import json
from dataclasses import replace

import mujoco
import numpy as np

from sim.runner.build import make_sonar, object_class_of, pipeline_config, world_spec_from_scenario
from sim.scenario.schema import load_scenario
from sim.world import build_world
from slam.frontend.extended_objects import make_shadow_db
from slam.frontend.sidescan_records import PingRecord
from slam.pipeline.config import make_frontend

LEGS = {  # name: (x centre m, line y m, heading deg)
    "A_rock": (-30, -30, 0),
    "A_wreck": (10, -30, 0),
    "B_rock": (-30, 0, 180),
    "B_wreck": (10, 0, 180),
    "B_rock15": (42, 0, 180),
    "B_branch": (-15, 0, 180),
    "B_manq": (25, 0, 180),
    "C_rock15": (42, 30, 0),
    "C_branch": (-15, 30, 0),
    "C_manq": (25, 30, 0),
}


def contrast(img, lab_all, slant, dr_db):
    """Per object and side: highlight over the seabed's 75th percentile within +-1.5 m
    slant (dB: median, p90, max), clipped fraction (samples at the leg's maximum), rows
    with a true shadow (>= 3 samples labelled no-return behind the object) and its median
    length (m), and the shadow test's median depth over those samples."""
    S = img.shape[1] // 2
    db = img.astype(np.float64) * dr_db
    rel = make_shadow_db(True, dr_db)(img.astype(np.float32))
    top = img.max()
    bw = float(slant[1] - slant[0])
    for port in (True, False):
        sl = (slice(None), slice(S - 1, None, -1)) if port else (slice(None), slice(S, None))
        lab, d, r, raw = lab_all[sl], db[sl], rel[sl], img[sl]
        for k in sorted(set(np.unique(lab).tolist()) - {0, -1}):
            m = lab == k
            cols = np.flatnonzero(m.any(0))
            band = np.zeros(S, bool)
            band[max(0, cols[0] - round(1.5 / bw)) : cols[-1] + round(1.5 / bw) + 1] = True
            sb = (lab == 0) & band[None, :]
            hi = d[m] - np.percentile(d[sb], 75)
            lens, depth = [], []
            for i in np.flatnonzero(m.any(1)):
                far = np.flatnonzero(m[i]).max()
                j = far + 1
                while j < S and lab[i, j] == -1:
                    j += 1
                lens.append(j - far - 1)
                if j - far - 1 >= 3:
                    depth.append(np.median(r[i, far + 1 : j]))
            lens = np.array(lens)
            print(
                f"  object {k} {'port' if port else 'stbd'}: {m.sum()} px, slant "
                f"{slant[cols[0]]:.1f}-{slant[cols[-1]]:.1f} m; highlight median/p90/max "
                f"{np.median(hi):+.1f}/{np.percentile(hi, 90):+.1f}/{hi.max():+.1f} dB; "
                f"clipped {np.mean(raw[m] >= top):.2f} (seabed {np.mean(raw[sb] >= top):.3f}); "
                f"true shadow on {np.mean(lens >= 3):.0%} of rows, median {np.median(lens) * bw:.2f} m, "
                f"read {np.median(depth) if depth else np.nan:+.1f} dB"
            )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scenario")
    ap.add_argument("out", help="output prefix: OUT_<leg>.npz")
    ap.add_argument("--legs", default=",".join(LEGS))
    ap.add_argument("--seed", type=int, default=12)
    ap.add_argument("--pings", type=int, default=260)
    ap.add_argument("--altitude", type=float, default=8.0)
    ap.add_argument("--set", default="{}", help="JSON overrides of the sonar")
    ap.add_argument("--contrast", action="store_true")
    a = ap.parse_args()
    scn = load_scenario(a.scenario)
    vs = scn.vehicles[0]
    world = build_world(world_spec_from_scenario(scn))
    sp = vs.sonars[0]
    sp = replace(sp, overrides={**dict(sp.overrides), **json.loads(a.set)})
    rng = np.random.default_rng(a.seed)
    rt = make_sonar(world, vs.name, sp, rng)
    son, pc = rt.sonar, pipeline_config(vs)
    m, d = world.model, world.data
    q = m.jnt_qposadr[m.body_jntadr[world.vehicles[vs.name].body_id]]
    rate, step = son.config.ping_rate_hz, vs.mission.speed_mps / son.config.ping_rate_hz
    print("objects:", [(o.id, o.class_name) for o in world.objects])
    for name in a.legs.split(","):
        xc, y, hd = LEGS[name]
        sgn, th = (1 if hd == 0 else -1), np.deg2rad(hd)
        x0 = xc - sgn * step * a.pings / 2
        z0 = float(world.seabed_height(np.array([[xc, y]]))[0]) + a.altitude
        fe = make_frontend(rt.geometry, pc, class_of=object_class_of(world))
        rows, labels, alt, dets = [], [], [], []
        for k in range(a.pings):
            x = x0 + sgn * k * step
            d.qpos[q : q + 3] = (x, y, z0)
            d.qpos[q + 3 : q + 7] = (np.cos(th / 2), 0, 0, np.sin(th / 2))
            mujoco.mj_forward(m, d)
            p = son.ping(d, rng)
            S = p.intensity.size // 2
            rows.append(p.intensity), labels.append(p.labels), alt.append(p.altitude)
            rec = PingRecord(
                k / rate, p.intensity, p.slant_range[S:], float(p.altitude),
                vs.mission.speed_mps, p.labels, np.array([x, y, th]),
            )  # fmt: skip
            res = fe.add(rec)
            dets += res.detections if res is not None else []
        res = fe.flush()
        dets += res.detections if res is not None else []
        img, lab = np.stack(rows), np.stack(labels)
        slant = p.slant_range[S:]
        np.savez_compressed(f"{a.out}_{name}.npz", I=img, L=lab, alt=np.array(alt), slant=slant)
        found = [(x.ping, x.side, round(x.ground_range, 1), x.object_id) for x in dets]
        print(f"{name}: detections (ping, side, ground m, object id) {found}")
        if a.contrast:
            contrast(img, lab, slant, son.config.acoustic.dynamic_range_db)


if __name__ == "__main__":
    main()

"""Sonar speed: rays/s of both ray backends, SSS pings/s, FLS frames/s, MSIS pings/s.

Scene: 200 m × 200 m rolling mesh seabed (224 × 224 quads ≈ 100k triangles) with a dozen
static objects and one moving object, vehicle 10 m above it moving along x between pings.
Targets (issue 3, this 2-core machine): SSS 2 × 1000 samples ≥ 500 pings/s, FLS
256 beams × 512 bins × 16 rays/beam ≥ 30 frames/s. Embree and MuJoCo backends are timed
side by side in the same run. Rates are given by wall clock (``*_per_s_*``) and by this
process's CPU time (``*_per_cpu_s_*``, single-threaded work, so equal to the wall rate on
an idle core; on a shared machine the wall rate drops with the load average, also printed).

    undersea bench sonar [--json] [--pings N] [--frames N] [--quick] [--pre DIR] [--main DIR]

The SSS ping is also profiled (cProfile, process CPU time): ms per ping by stage (cast,
echo formation, receive chain, rotation/altitude/record) and of the largest sim/sonar
functions, numpy calls charged to the function that made them.

``--pre DIR`` / ``--main DIR``: also time a default SSS ping and the 256 × 512 × 16 FLS
frame with the sonar code of another checkout (``--pre``: the code before issue 16, e.g.
``git worktree add /tmp/pre f591a7e``; ``--main``: main when this round started), called
in turn with this code's at each pose in this run; prints this code's speed-up over each
(issue 16's FLS goal: ≥ 3× the pre-issue-16 code).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:  # loaded by file path (undersea bench): the checkout's root
    sys.path.insert(0, str(REPO))

from benchmarks.sonar_profile import ping_profile, print_profile  # noqa: E402


def _scene(cells: int):
    from sim.sonar.scenes import SceneObject, build_scene

    rng = np.random.default_rng(0)
    objs = []
    for k in range(12):
        x, y = rng.uniform(-60, 60), rng.choice([-1, 1]) * rng.uniform(5, 40)
        kind = ["box", "cylinder", "sphere"][k % 3]
        size = {"box": (1.0, 0.6, 0.5), "cylinder": (0.4, 1.5), "sphere": (0.7,)}[kind]
        objs.append(
            SceneObject(kind, (x, y, 0.6), size, euler_deg=(0, 90 if kind == "cylinder" else 0, 30))
        )
    objs.append(SceneObject("box", (0.0, 20.0, 1.0), (1.0, 1.0, 1.0), moving=True))
    return build_scene(
        altitude=10.0, objects=objs, seabed_cells=cells, relief=0.5, seabed_size=200.0
    )


_CPU: dict[int, float] = {}


def _time(fn, n: int) -> float:
    """Calls per second by wall clock; the process-CPU-time rate of the same run is kept in
    ``_CPU[id(fn)]`` (less sensitive to other jobs sharing the machine)."""
    fn(0)  # warm-up
    t0, c0 = time.perf_counter(), time.process_time()
    for k in range(n):
        fn(k)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    _CPU[id(fn)] = n / max(cpu, 1e-9)
    return n / wall


def _cpu(fn) -> float:
    c0 = time.process_time()
    fn()
    return time.process_time() - c0


def ping_vs_cast(sss, sc, mover, n: int) -> dict:
    """Process-CPU ms of a whole SSS ping, of the project's cast of that ping's rays (the
    fan and the nadir probe in one batch, as the ping casts them, moving-body test
    included) and of bare ``embreex`` (``EmbreeScene.run`` on the same rays, prebuilt
    float32 origins and directions), called in turn at each pose; medians and ratios."""

    d = sc.data
    mt = sss.mount
    be = mt.backend
    rng = np.random.default_rng(0)
    t_ping, t_cast, t_bare = [], [], []
    for k in range(n + 1):
        mover(k)
        sss.ping(d, rng)  # also refreshes the cached fan for this pose
        fan = sss._fan_cache[1]
        p0, R = mt.pose(d, mt.site_ids[0])
        dirs = np.concatenate([fan.directions @ R.T, sss._probe_local @ R.T])
        cones = fan.cones.rotated(R)
        o32 = np.empty((dirs.shape[0], 3), np.float32)
        o32[:] = p0 - be.center
        d32 = np.ascontiguousarray(dirs, np.float32)
        tb = _cpu(
            lambda o32=o32, d32=d32: be.scene.run(
                o32, d32, np.full(len(d32), mt.cutoff, np.float32), output=1
            )
        )
        tc = _cpu(lambda p0=p0, dirs=dirs, cones=cones: be.cast(d, p0, dirs, mt.cutoff, cones))
        tp = _cpu(lambda: sss.ping(d, rng))
        if k:  # the first round warms up
            t_bare.append(tb)
            t_cast.append(tc)
            t_ping.append(tp)
    ping, cast, bare = (1e3 * float(np.median(x)) for x in (t_ping, t_cast, t_bare))
    # the same ratio of the fastest calls: less sensitive to other jobs on the machine
    # (cache and memory-bandwidth contention inflate the echo passes more than the cast)
    ping_min, cast_min = (1e3 * float(np.min(x)) for x in (t_ping, t_cast))
    return {
        "sss_ping_over_cast_of_minima": round(ping_min / cast_min, 2),
        "sss_ms_per_ping_total_min": round(ping_min, 3),
        "sss_ms_per_ping_cast_min": round(cast_min, 3),
        "sss_ms_per_ping_total": round(ping, 3),
        "sss_ms_per_ping_cast": round(cast, 3),
        "sss_ms_per_ping_bare_embreex": round(bare, 3),
        "sss_rays_per_ping_cast": int(dirs.shape[0]),
        "sss_ping_over_cast": round(ping / cast, 2),
        "sss_cast_over_bare_embreex": round(cast / bare, 2),
    }


def fls_echo_share(cfg, sc, mover, n: int) -> dict:
    """Process-CPU ms of an FLS frame and of its ray cast alone, in turn at each pose."""
    from sim.sonar import ForwardLookingSonar

    d = sc.data
    fls = ForwardLookingSonar(
        cfg, sc.model, d, sc.sites["fls"], sc.geom_object_id, sc.geom_reflectivity, sc.water
    )
    mt = fls.mount
    rng = np.random.default_rng(0)
    t_frame, t_cast = [], []
    for k in range(n + 1):
        mover(k)
        p0, R = mt.pose(d, mt.site_ids[0])
        dirs = fls._d_local @ R.T
        cones = fls._cones.rotated(R)
        tc = _cpu(
            lambda p0=p0, dirs=dirs, cones=cones: mt.backend.cast(d, p0, dirs, mt.cutoff, cones)
        )
        tf = _cpu(lambda: fls.frame(d, rng))
        if k:
            t_cast.append(tc)
            t_frame.append(tf)
    frame, cast = (1e3 * float(np.median(x)) for x in (t_frame, t_cast))
    return {
        "fls_ms_per_frame_total": round(frame, 3),
        "fls_ms_per_frame_cast": round(cast, 3),
        "fls_frame_over_cast": round(frame / cast, 2),
    }


def _sonar_api(root: str):
    """(SideScanSonar, ForwardLookingSonar, preset) of the ``sim.sonar`` package under
    ``root`` (another checkout of this repository), imported beside this one: its modules
    are loaded under the ``sim`` names, kept alive by the returned classes, and this
    checkout's modules put back afterwards."""
    from pathlib import Path

    if not (Path(root) / "sim" / "sonar" / "__init__.py").is_file():
        raise SystemExit(f"--compare {root!r}: no sim/sonar package there")
    ours = {k: v for k, v in sys.modules.items() if k == "sim" or k.startswith("sim.")}
    for k in ours:
        del sys.modules[k]
    sys.path.insert(0, str(root))
    try:
        import sim.sonar as theirs

        api = (theirs.SideScanSonar, theirs.ForwardLookingSonar, theirs.preset)
    finally:
        sys.path.remove(str(root))
        for k in [k for k in sys.modules if k == "sim" or k.startswith("sim.")]:
            del sys.modules[k]
        sys.modules.update(ours)
    return api


def compare_codes(roots: dict[str, str], sc, mover, n: int) -> dict:
    """Process-CPU ms of a default SSS ping and of a 256 × 512 × 16 FLS frame with this
    code and with the code under each of ``roots`` (label: checkout directory), called in
    turn at every pose (the first pose warms up, FLS at every fourth pose); medians and
    this code's speed-up over each."""
    from sim.sonar import ForwardLookingSonar, SideScanSonar, preset

    d = sc.data
    args = (sc.geom_object_id, sc.geom_reflectivity, sc.water)
    fls_kw = dict(n_beams=256, n_bins=512, rays_per_beam=16, max_range=100.0)
    codes = {"this": (SideScanSonar, ForwardLookingSonar, preset)}
    codes.update({label: _sonar_api(r) for label, r in roots.items()})
    sonars = {}
    for name, (S, F, P) in codes.items():
        sss = S(P("deepeye680d"), sc.model, d, sc.sites["sss"], *args)
        fls = F(P("blueview_p900_90", **fls_kw), sc.model, d, sc.sites["fls"], *args)
        sonars[name] = (sss, fls, np.random.default_rng(0))
    t = {(name, kind): [] for name in codes for kind in ("sss", "fls")}
    for k in range(n + 1):
        mover(k)
        for name, (sss, fls, rng) in sonars.items():
            ts = _cpu(lambda sss=sss, rng=rng: sss.ping(d, rng))
            tf = _cpu(lambda fls=fls, rng=rng: fls.frame(d, rng)) if k % 4 == 0 else None
            if k:
                t[name, "sss"].append(ts)
                if tf is not None:
                    t[name, "fls"].append(tf)
    ms = {key: 1e3 * float(np.median(v)) for key, v in t.items()}
    out = {"compare_ms_sss_ping_this": round(ms["this", "sss"], 3)}
    out["compare_ms_fls_frame_this"] = round(ms["this", "fls"], 3)
    for r in roots:
        out[f"compare_dir_{r}"] = roots[r]
        out[f"compare_ms_sss_ping_{r}"] = round(ms[r, "sss"], 3)
        out[f"compare_ms_fls_frame_{r}"] = round(ms[r, "fls"], 3)
        out[f"compare_sss_speedup_over_{r}"] = round(ms[r, "sss"] / ms["this", "sss"], 2)
        out[f"compare_fls_speedup_over_{r}"] = round(ms[r, "fls"] / ms["this", "fls"], 2)
    return out


#: issue 16's goals for the ratios measured in one run (name: (comparison, goal, note))
GOALS = {
    "sss_ping_over_cast": ("<=", 1.5, "SSS ping total / its own ray cast"),
    "sss_cast_over_bare_embreex": ("<=", 1.2, "project's cast / bare embreex, same rays"),
}


def print_goals(out: dict) -> None:
    """Each issue-16 ratio beside its goal, with the references measured in this run."""
    print(f"issue 16 ratios (process CPU, load average {out.get('load_average_1min', '?')}):")
    refs = {
        "sss_ping_over_cast": "sss_ms_per_ping_total sss_ms_per_ping_cast",
        "sss_cast_over_bare_embreex": "sss_ms_per_ping_cast sss_ms_per_ping_bare_embreex",
    }
    for k, (cmp, goal, what) in GOALS.items():
        v = out[k]
        ok = v <= goal if cmp == "<=" else v >= goal
        a, b = (out[x] for x in refs[k].split())
        print(
            f"  {what:42s} {a:7.3f} / {b:7.3f} ms = {v:5.2f}x   goal {cmp} {goal}x"
            f"   {'met' if ok else 'MISSED'}"
        )
    print(
        f"  {'(same, fastest call of each)':42s} {out['sss_ms_per_ping_total_min']:7.3f} / "
        f"{out['sss_ms_per_ping_cast_min']:7.3f} ms = {out['sss_ping_over_cast_of_minima']:5.2f}x"
        "   (information; the goal is on the medians above)"
    )
    print_profile(out)
    for label in ("pre", "main"):
        if f"compare_fls_speedup_over_{label}" not in out:
            continue
        for kind, name in (("sss", "SSS ping"), ("fls", "FLS 256x512x16 frame")):
            unit = "ping" if kind == "sss" else "frame"
            this = out[f"compare_ms_{kind}_{unit}_this"]
            them = out[f"compare_ms_{kind}_{unit}_{label}"]
            v = out[f"compare_{kind}_speedup_over_{label}"]
            goal = "   goal >= 3x " + ("met" if v >= 3.0 else "MISSED")
            print(
                f"  {name + ' speed-up over ' + label:42s} {them:7.3f} / {this:7.3f} ms ="
                f" {v:5.2f}x{goal if (kind, label) == ('fls', 'pre') else ''}"
            )
    if "compare_fls_speedup_over_pre" not in out:
        print(
            f"  {'FLS 256x512x16 frames per CPU s':42s} {out['fls_frames_per_cpu_s_embree']:6.1f}"
            "    goal >= 3x the pre-issue-16 code: run with --pre DIR (checkout of f591a7e)"
        )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="undersea bench sonar", description=__doc__.splitlines()[0])
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    ap.add_argument("--pings", type=int, default=400, help="SSS pings per backend (default 400)")
    ap.add_argument("--frames", type=int, default=40, help="FLS frames per backend (default 40)")
    ap.add_argument("--quick", action="store_true", help="small counts for a smoke run")
    ap.add_argument("--pre", metavar="DIR", help="checkout of the pre-issue-16 code to compare")
    ap.add_argument("--main", metavar="DIR", help="checkout of main at the round's start")
    args = ap.parse_args(argv)
    if args.quick:
        args.pings, args.frames = 20, 3

    from sim.sonar import ForwardLookingSonar, MSISSonar, SideScanSonar, preset
    from sim.sonar.rays import EmbreeRays, MujocoRays

    t0 = time.perf_counter()
    sc = _scene(224)
    build_s = time.perf_counter() - t0
    m, d = sc.model, sc.data
    ntri = int(m.nmeshface)
    out: dict = {
        "machine_cpus": os.cpu_count(),
        "triangles": ntri,
        "scene_build_s": round(build_s, 3),
    }

    # raw ray throughput: 100k rays from the vehicle towards the seabed
    rng = np.random.default_rng(1)
    dirs = rng.normal(size=(100_000, 3))
    dirs[:, 2] = -np.abs(dirs[:, 2]) - 0.3
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    o = d.site_xpos[sc.sites["sss"]].copy()
    t0 = time.perf_counter()
    emb = EmbreeRays(m, d, sc.vehicle_body)
    out["embree_scene_build_s"] = round(time.perf_counter() - t0, 3)
    muj = MujocoRays(m, sc.vehicle_body)

    def cast_e(k):
        emb.cast(d, o, dirs, 200.0)

    def cast_m(k):
        muj.cast(d, o, dirs, 200.0)

    n_rays = dirs.shape[0]
    out["rays_per_s_embree"] = round(_time(cast_e, 5) * n_rays)
    out["rays_per_cpu_s_embree"] = round(_CPU[id(cast_e)] * n_rays)
    out["rays_per_s_mujoco"] = round(_time(cast_m, 2) * n_rays)
    out["rays_per_cpu_s_mujoco"] = round(_CPU[id(cast_m)] * n_rays)

    def mover(k):
        sc.move_vehicle(-50.0 + 0.1 * (k % 1000))

    args_common = (m, d)
    sss_cfg = preset("deepeye680d")  # 2 × 1000 samples, 50 m
    fls_cfg = preset("blueview_p900_90", n_beams=256, n_bins=512, rays_per_beam=16, max_range=100.0)
    for backend, n_p, n_f in (
        ("embree", args.pings, args.frames),
        ("mujoco", max(5, args.pings // 8), max(2, args.frames // 4)),
    ):
        sss = SideScanSonar(
            sss_cfg,
            *args_common,
            sc.sites["sss"],
            sc.geom_object_id,
            sc.geom_reflectivity,
            sc.water,
            backend=backend,
        )
        prng = np.random.default_rng(0)

        def ping(k, sss=sss, prng=prng):
            mover(k)
            sss.ping(d, prng)

        pps = _time(ping, n_p)
        out[f"sss_pings_per_cpu_s_{backend}"] = round(_CPU[id(ping)], 1)
        theta, _ = sss.depression_angles(10.0)
        rays_per_ping = 2 * theta.size * sss_cfg.rays_along_track + 14
        out[f"sss_pings_per_s_{backend}"] = round(pps, 1)
        out["sss_rays_per_ping"] = int(rays_per_ping)
        fls = ForwardLookingSonar(
            fls_cfg,
            *args_common,
            sc.sites["fls"],
            sc.geom_object_id,
            sc.geom_reflectivity,
            sc.water,
            backend=backend,
        )

        def frame(k, fls=fls, prng=prng):
            mover(k)
            fls.frame(d, prng)

        out[f"fls_frames_per_s_{backend}"] = round(_time(frame, n_f), 1)
        out[f"fls_frames_per_cpu_s_{backend}"] = round(_CPU[id(frame)], 1)
        out["fls_rays_per_frame"] = fls.rays_per_frame
    # SSS with one along-track ray per depression angle (the along-track beam, 0.2°, is 17 cm
    # wide at 50 m): the cheaper variant
    sss1 = SideScanSonar(
        preset("deepeye680d", rays_along_track=1),
        m,
        d,
        sc.sites["sss"],
        sc.geom_object_id,
        sc.geom_reflectivity,
        sc.water,
    )
    prng1 = np.random.default_rng(0)

    def ping1(k):
        mover(k)
        sss1.ping(d, prng1)

    out["sss_pings_per_s_embree_1_along_track_ray"] = round(_time(ping1, args.pings), 1)
    out["sss_pings_per_cpu_s_embree_1_along_track_ray"] = round(_CPU[id(ping1)], 1)
    # issue 16: a default SSS ping vs its own cast vs bare embreex on the same rays, and
    # the FLS frame's share of echo formation, interleaved call by call in this run
    sss = SideScanSonar(
        sss_cfg, m, d, sc.sites["sss"], sc.geom_object_id, sc.geom_reflectivity, sc.water
    )
    out.update(ping_vs_cast(sss, sc, mover, args.pings))
    out.update(ping_profile(sss, sc, mover, max(20, args.pings // 2)))
    out.update(fls_echo_share(fls_cfg, sc, mover, max(3, args.frames // 2)))
    roots = {k: v for k, v in (("pre", args.pre), ("main", args.main)) if v}
    if roots:
        out.update(compare_codes(roots, sc, mover, max(8, args.pings // 3)))
    msis = MSISSonar(
        preset("msis"),
        *args_common,
        sc.sites["msis"],
        sc.geom_object_id,
        sc.geom_reflectivity,
        sc.water,
    )
    prng = np.random.default_rng(0)
    out["msis_pings_per_s_embree"] = round(
        _time(lambda k: msis.ping(d, prng, 0.01 * k), max(20, args.pings // 4)), 1
    )
    # echo formation alone (rays already cast), SSS
    out["targets"] = {"sss_pings_per_s": 500, "fls_frames_per_s": 30}
    out["meets_targets_embree_wall_clock"] = {
        "sss": out["sss_pings_per_s_embree"] >= 500,
        "fls": out["fls_frames_per_s_embree"] >= 30,
    }
    out["meets_targets_embree_cpu_time"] = {
        "sss": out["sss_pings_per_cpu_s_embree"] >= 500,
        "fls": out["fls_frames_per_cpu_s_embree"] >= 30,
    }
    try:
        out["load_average_1min"] = round(os.getloadavg()[0], 2)
    except OSError:
        pass
    out["goals_issue16"] = {k: {"cmp": c, "goal": g} for k, (c, g, _) in GOALS.items()}
    if args.json:
        print(json.dumps(out))
    else:
        for k, v in out.items():
            if not k.startswith("sss_profile_ms_per_ping_"):
                print(f"{k:>28}: {v}")
        print_goals(out)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

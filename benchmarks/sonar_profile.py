"""cProfile breakdown of a side-scan ping for ``undersea bench sonar``: process CPU ms per
ping by stage (cast, echo formation, receive chain, rotation/altitude/record) and of the
largest sim/sonar functions, numpy and library calls charged to the sim/sonar function
that made them."""

from __future__ import annotations

import cProfile
import os
import pstats
import time

import numpy as np

#: the ping's stages by the sim/sonar module a function lives in (numpy and library
#: functions are charged to the sim/sonar function that called them)
STAGES = {
    "cast (Embree, moving-body test, hit gather)": ("rays.py", "ray_cones.py"),
    "echo formation (compiled passes + numpy glue)": (
        "echo.py",
        "echo_kernels.py",
        "echo_image.py",
    ),
    "speckle, noise, TVG, log compression (+ probe altitude)": (
        "sss_kernels.py",
        "acoustics.py",
        "chain.py",
        "speckle.py",
        "receiver.py",
    ),
    "fan rotation, altitude, ping record": ("sidescan.py", "mount.py", "waterfall.py"),
}


def _owner(func, stats, seen=()) -> tuple:
    """The sim/sonar function charged with ``func``'s own time: itself, else (following
    the caller that spent most time in it) its nearest sim/sonar caller."""
    if "sim/sonar/" in func[0].replace(os.sep, "/") or func in seen:
        return func
    callers = stats[func][4]
    if not callers:
        return func
    top = max(callers, key=lambda c: callers[c][3])
    return _owner(top, stats, (*seen, func))


def ping_profile(sss, sc, mover, n: int, top: int = 12) -> dict:
    """cProfile (process CPU time) of ``n`` SSS pings: ms per ping by stage
    (:data:`STAGES`) and of the ``top`` sim/sonar functions by own time (numpy calls
    charged to their caller); profiling overhead inflates every figure alike."""
    d = sc.data
    rng = np.random.default_rng(0)
    prof = cProfile.Profile(time.process_time)
    for k in range(n + 1):
        mover(k)
        if k:
            prof.enable()
        sss.ping(d, rng)
        prof.disable()
    stats = pstats.Stats(prof).stats
    own: dict[tuple, float] = {}
    for func, (_, _, tt, _, _) in stats.items():
        key = _owner(func, stats)
        own[key] = own.get(key, 0.0) + tt
    total = sum(own.values())
    stage = {name: 0.0 for name in STAGES}
    stage["other (bench loop, Python)"] = 0.0
    for (file, _, _), t in own.items():
        base = os.path.basename(file)
        name = next((k for k, v in STAGES.items() if base in v and "sim" in file), None)
        stage[name or "other (bench loop, Python)"] += t
    funcs = sorted(own.items(), key=lambda kv: -kv[1])[:top]
    return {
        "sss_profile_ms_per_ping_total": round(1e3 * total / n, 3),
        "sss_profile_ms_per_ping_by_stage": {k: round(1e3 * v / n, 3) for k, v in stage.items()},
        "sss_profile_ms_per_ping_top": {
            f"{os.path.basename(f)}:{name}": round(1e3 * t / n, 3) for (f, _, name), t in funcs
        },
    }


def print_profile(out: dict) -> None:
    """The SSS ping's cProfile breakdown (:func:`ping_profile`)."""
    if "sss_profile_ms_per_ping_total" not in out:
        return
    print(
        f"  SSS ping profile (cProfile, process CPU, overhead included):"
        f" {out['sss_profile_ms_per_ping_total']:.3f} ms/ping"
    )
    for name, ms in out["sss_profile_ms_per_ping_by_stage"].items():
        print(f"    {name:52s} {ms:7.3f} ms")
    print("    largest functions (own time, numpy charged to the caller):")
    for name, ms in out["sss_profile_ms_per_ping_top"].items():
        print(f"      {name:50s} {ms:7.3f} ms")

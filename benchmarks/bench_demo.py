"""`undersea demo` against another checkout, alternated in one session (issue 16's
"RTF ≥ 3× today, same machine").

Each run is a fresh process of ``undersea demo --duration D --no-progress`` (this tree,
then the ``--against`` tree, ``--runs`` times in turn); per run: the printed real-time
factor (metrics.json ``timing``: run_scenario's start to the loop's end, world build
and in-loop compiles included), the process's CPU seconds (user + sys of the child:
steadier than wall clock on a shared machine) and the load average at its start.
Printed: medians per tree and the ratios this tree / other (RTF) and other / this
(CPU), beside the goal. The first run of a fresh checkout compiles its numba cache
(tens of seconds): run once before measuring (``--warmup``), and say so.

    undersea bench demo --against /tmp/s6pre [--runs 3] [--duration 60] [--warmup] [--json]

(``git worktree add /tmp/s6pre f591a7e``: the pre-round code, whose default demo is the
420 s survey, hence the explicit ``--duration``.)
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

GOAL_RTF_RATIO = 3.0


def _tree() -> str:
    return str(Path(__file__).resolve().parents[1])


def run_demo(tree: str, duration: float, out: Path) -> dict:
    """One demo run of ``tree`` in a subprocess: printed RTF, CPU s, wall s, load."""
    env = {**os.environ, "PYTHONPATH": tree}
    cmd = [sys.executable, "-m", "sim.cli.main", "demo", "--duration", f"{duration:g}"]
    cmd += ["--out", str(out), "--overwrite", "--no-progress"]
    load = os.getloadavg()[0]
    ru0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    r = subprocess.run(cmd, cwd=tree, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    ru1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if r.returncode != 0:
        raise SystemExit(f"demo in {tree} failed:\n{r.stderr[-2000:]}")
    timing = json.loads((out / "metrics.json").read_text())["timing"]
    cpu = (ru1.ru_utime - ru0.ru_utime) + (ru1.ru_stime - ru0.ru_stime)
    return {
        "rtf": timing["real_time_factor"],
        "cpu_s": cpu,
        "cpu_rtf": duration / cpu,
        "wall_s": wall,
        "load": load,
        "stages_s": timing["stages_s"],
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="undersea bench demo", description=__doc__.split("\n")[0])
    ap.add_argument("--against", required=True, help="another checkout (e.g. a git worktree)")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--duration", type=float, default=60.0, help="simulated s (default 60)")
    ap.add_argument("--warmup", action="store_true", help="one unmeasured run of each first")
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args(argv)
    if a.runs < 1 or not a.duration > 0:
        ap.error(f"--runs must be >= 1 and --duration > 0, got {a.runs}, {a.duration}")
    other = str(Path(a.against).resolve())
    if not (Path(other) / "sim" / "cli" / "main.py").is_file():
        ap.error(f"--against {a.against}: no undersea checkout there (sim/cli/main.py)")
    trees = {"this": _tree(), "other": other}
    res: dict[str, list[dict]] = {"this": [], "other": []}
    with tempfile.TemporaryDirectory() as tmp:
        if a.warmup:
            for k, t in trees.items():
                run_demo(t, a.duration, Path(tmp) / f"warm-{k}")
        for i in range(a.runs):
            for k, t in trees.items():
                res[k].append(run_demo(t, a.duration, Path(tmp) / f"{k}-{i}"))
    med = {
        k: {m: statistics.median(r[m] for r in runs) for m in ("rtf", "cpu_s", "cpu_rtf", "load")}
        for k, runs in res.items()
    }
    ratio_rtf = med["this"]["rtf"] / med["other"]["rtf"]
    ratio_cpu = med["other"]["cpu_s"] / med["this"]["cpu_s"]
    if a.json:
        print(
            json.dumps({"runs": res, "median": med, "ratio_rtf": ratio_rtf, "ratio_cpu": ratio_cpu})
        )
        return 0
    print(f"undersea demo, {a.duration:g} s simulated, {a.runs} runs each alternated")
    for k in ("this", "other"):
        m = med[k]
        rtfs = ", ".join(f"{r['rtf']:.2f}" for r in res[k])
        print(
            f"  {k:5s} {trees[k]}: printed RTF {rtfs} (median {m['rtf']:.2f}); "
            f"CPU {m['cpu_s']:.1f} s (CPU RTF {m['cpu_rtf']:.2f}); load {m['load']:.1f}"
        )
    print(f"  ratio RTF {ratio_rtf:.2f}x, CPU {ratio_cpu:.2f}x (goal >= {GOAL_RTF_RATIO:g}x)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

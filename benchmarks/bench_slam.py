"""``undersea bench slam [--json] [--runs N] [--sizes 100,500,2000] [--skip-fastslam]``

1. Wall time of one full dense-loop run (example_webmap, two loops, dt 0.025 s: 17,382
   control steps, 1,931 scans) per estimator, same seed and data, in the same process;
   the ratio FastSLAM 2.0 / AEKF (the reference's MATLAB: 525.5 s / 137.9 s = 3.81).
   ``aekf`` is the reference preset (Bailey's filter, as the thesis timed it), beside
   ``aekf-fej`` and ``aekf-consistent`` (the AEKF's default preset).
   Target: AEKF <= 1 s per run. Estimator time = its predict/update/landmarks calls only;
   the simulation is reported separately.
2. AEKF update time versus number of landmarks (100, 500, 2,000): one scan = predict +
   gated ML association against all landmarks + batch update with 2 observations; the
   log-log slope shows the O(n²) growth. Goal: 2,000 landmarks at >= 50 updates/s.
3. The same FastSLAM 2.0 / AEKF ratio on the line map (reference's MATLAB: 594.1 s / 99.8 s
   = 5.95), then the load average at start and end of the run.
4. With ``--bailey-dir DIR`` (or ``$UNDERSEA_BAILEY_DIR``): Tim Bailey's original
   ``ekfslam_v1`` (``ekfslam_sim.m``, ``configfile.m`` and the utilities it calls; not
   shipped here, it is not ours to redistribute) run by GNU Octave on the same dense loop
   in the same run, and the Octave / AEKF time ratio (target >= 25). Without Octave or the
   code, the output says which is missing.

5. Issue 16's "consistent preset ≤ reference preset" in two readings, CPU time of the
   estimator loop per dense-loop run, both in this one run: (a) consistent / reference
   of this tree; (b) with ``--against TREE`` (another checkout, e.g. the round's start
   ``git worktree add /tmp/aekfpre f591a7e``), this tree's consistent preset / that
   tree's reference preset, run by that tree's own code in a subprocess right after this
   tree's runs, on the same seeds and data. Both printed beside the goal (≤ 1) with the
   load average.
6. Issue 12's navigation bias states: CPU time of one dense-loop run of ``NavBiasSlam``
   around the consistent AEKF against the AEKF alone, with the bias regression by
   Cholesky solve and by the pseudo-inverse it replaced (``--skip-nav-bias`` skips it).

BLAS is limited to one thread (the filters' small matrices only lose from threads on a
shared 2-core machine); ``--blas-threads`` changes that for the scaling part.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:  # loaded by file path (undersea bench): the checkout's root
    sys.path.insert(0, str(REPO))

from benchmarks.other_tree import json_from_tree  # noqa: E402

# The reference's MATLAB run times (thesis ch. 6): AEKF, FastSLAM 2.0 (s).
REFERENCE_MATLAB_S = {"dense-loop": (137.937051, 525.526820), "line": (99.8, 594.1)}


def _dense_loop_times(
    runs: int, skip_fastslam: bool, skip_isam2: bool, experiment: str = "dense-loop", full=True
) -> dict:
    from slam.experiments import get_experiment, run_once
    from slam.sim2d import simulate_run

    spec = get_experiment(experiment)
    names = ["aekf", "aekf-fej", "aekf-consistent"] if full else ["aekf"]
    if not skip_fastslam:
        names.append("fastslam2")
    if not skip_isam2:
        names.append("isam2")
    out: dict = {"experiment": experiment, "runs": runs, "n_scans": None, "estimators": {}}
    sim_t = []
    for r in range(runs):
        ss = np.random.SeedSequence(r)
        t0 = time.perf_counter()
        run = simulate_run(
            spec.map.landmarks, spec.map.waypoints, spec.sim, np.random.default_rng(ss.spawn(2)[0])
        )
        sim_t.append(time.perf_counter() - t0)
        out["n_scans"] = run.n_scans
        for name in names:
            est, params = {
                # the thesis's AEKF is Bailey's filter: the reference preset (the AEKF's
                # default is the consistent one), so the ratio compares what it compared
                "aekf": ("aekf", {"preset": "reference"}),
                "aekf-fej": ("aekf", {"preset": "reference", "jacobians": "fej"}),
                "aekf-consistent": ("aekf", {"preset": "consistent"}),
            }.get(name, (name, {}))
            try:
                res = run_once(spec, est, r, params, sim_run=run)
            except ImportError as exc:
                out["estimators"][name] = {"error": str(exc)}
                continue
            d = out["estimators"].setdefault(
                name, {"time_s": [], "cpu_s": [], "landmark_rmse_m": []}
            )
            d["time_s"].append(res.time_s)
            d["cpu_s"].append(res.cpu_s)
            d["landmark_rmse_m"].append(res.landmark_rmse)
    out["simulation_s_mean"] = float(np.mean(sim_t))
    for d in out["estimators"].values():
        if "time_s" in d:
            d["time_s_mean"] = float(np.mean(d["time_s"]))
            d["cpu_s_mean"] = float(np.mean(d["cpu_s"]))
            d["landmark_rmse_median_m"] = float(np.median(d["landmark_rmse_m"]))
    est = out["estimators"]
    if "fastslam2" in est and "time_s_mean" in est.get("fastslam2", {}):
        out["ratio_fastslam2_over_aekf"] = (
            est["fastslam2"]["time_s_mean"] / est["aekf"]["time_s_mean"]
        )
    if "time_s_mean" in est.get("isam2", {}):
        out["ratio_isam2_over_aekf"] = est["isam2"]["time_s_mean"] / est["aekf"]["time_s_mean"]
    if "cpu_s_mean" in est.get("aekf-consistent", {}) and "cpu_s_mean" in est.get("aekf", {}):
        # issue 16: the default (consistent) preset no slower than Bailey's filter
        out["ratio_consistent_over_reference_cpu"] = (
            est["aekf-consistent"]["cpu_s_mean"] / est["aekf"]["cpu_s_mean"]
        )
        out["goal_consistent_over_reference"] = 1.0
    t_aekf, t_fs = REFERENCE_MATLAB_S[experiment]
    out["reference_matlab_s"] = {"aekf": t_aekf, "fastslam2": t_fs, "ratio": t_fs / t_aekf}
    out["target_aekf_s"] = 1.0
    return out


#: Octave driver: Bailey's simulator on example_webmap (two loops at his configfile's
#: dt 0.025 s); the drawing functions it calls are shadowed by no-ops (``_NO_DRAW``) so
#: only the filter and the simulator are timed, as the AEKF is
_OCTAVE_DRIVER = """
addpath('{code}'); addpath('{stubs}'); load('{mat}');
t0 = tic; data = ekfslam_sim(lm, wp); t = toc(t0);
printf('BAILEY_SECONDS %.6f STEPS %d\\n', t, data.i);
"""
_NO_DRAW = ("figure", "plot", "patch", "set", "drawnow", "xlabel", "ylabel", "axis", "hold")


def _octave_bailey(bailey_dir: str | None, timeout_s: float = 900.0) -> dict:
    """Seconds of one run of Bailey's ekfslam_v1 in GNU Octave on the dense loop, or why not."""
    octave = shutil.which("octave") or shutil.which("octave-cli")
    if octave is None:
        return {"error": "GNU Octave not installed (apt-get install octave)"}
    if not bailey_dir or not (Path(bailey_dir) / "ekfslam_sim.m").is_file():
        return {
            "error": "Bailey's ekfslam_v1 not found: give --bailey-dir DIR (or "
            "UNDERSEA_BAILEY_DIR) holding ekfslam_sim.m, configfile.m and its utilities"
        }
    from scipy.io import savemat

    from slam.sim2d.maps import dense_loop_map

    m = dense_loop_map()
    with tempfile.TemporaryDirectory() as tmp:
        mat = Path(tmp) / "webmap.mat"
        stubs = Path(tmp) / "no_draw"
        stubs.mkdir()
        for name in _NO_DRAW:  # a handle-like 0 for every output asked for
            (stubs / f"{name}.m").write_text(
                f"function varargout = {name}(varargin)\n"
                "  varargout = num2cell(zeros(1, max(nargout, 1)));\nend\n"
            )
        savemat(
            mat, {"lm": np.asarray(m.landmarks, float).T, "wp": np.asarray(m.waypoints, float).T}
        )
        script = _OCTAVE_DRIVER.format(code=Path(bailey_dir).resolve(), stubs=stubs, mat=mat)
        try:
            r = subprocess.run(
                [octave, "--no-gui", "--no-window-system", "-q", "--eval", script],
                capture_output=True,
                text=True,
                timeout=timeout_s,
                cwd=tmp,
            )
        except subprocess.TimeoutExpired:
            return {"error": f"Octave run longer than {timeout_s:.0f} s"}
    for line in r.stdout.splitlines():
        if line.startswith("BAILEY_SECONDS"):
            f = line.split()
            return {"time_s": float(f[1]), "control_steps": int(f[3]), "octave": octave}
    return {"error": f"Octave failed (exit {r.returncode}): {r.stderr.strip()[-300:]}"}


def _nav_bias_times(runs: int) -> dict:
    """CPU seconds per dense-loop run (dt 0.025 s) of the consistent AEKF alone and inside
    ``NavBiasSlam`` (issue 12's navigation bias states, datasheet-sized prior), the latter
    with the bias regression by Cholesky solve (``_regression``, the default) and by the
    pseudo-inverse it replaced (``_regression_pinv``), in this one run; and the largest
    difference of the two paths' final bias estimate and pose."""
    from threadpoolctl import threadpool_limits

    import slam.estimators.nav_bias as nb
    from slam.estimators.aekf import AEKFSlam
    from slam.experiments import get_experiment
    from slam.sim2d import simulate_run

    spec = get_experiment("dense-loop")
    model = nb.NavBiasModel(
        hard_iron_std=np.radians(0.7),
        soft_iron_std=np.radians(0.3),
        drift_std=np.radians(0.5),
        scale_factor_std=0.002,
        misalignment_std=np.radians(0.1),
        velocity_bias_std=0.001,
    )
    solve = nb._regression
    cpu: dict = {"plain": [], "nav_bias": [], "nav_bias_pinv": []}
    max_diff = 0.0
    for r in range(runs):
        ss = np.random.SeedSequence(r)
        run = simulate_run(
            spec.map.landmarks, spec.map.waypoints, spec.sim, np.random.default_rng(ss.spawn(2)[0])
        )
        odo = [run.odometry(i) for i in range(run.n_scans)]
        obs = [run.observations(i) for i in range(run.n_scans)]
        finals = {}
        for name in cpu:
            nb._regression = nb._regression_pinv if name == "nav_bias_pinv" else solve
            try:
                est = AEKFSlam(preset="consistent", provisional_misses=3)
                if name != "plain":
                    est = nb.NavBiasSlam(est, model)
                c0 = time.process_time()
                with threadpool_limits(limits=1, user_api="blas"):  # as run_once does
                    for i in range(run.n_scans):
                        est.predict(odo[i])
                        est.update(obs[i])
                cpu[name].append(time.process_time() - c0)
            finally:
                nb._regression = solve
            if name != "plain":
                finals[name] = np.concatenate([est.beta, est.inner.x[:3]])
        max_diff = max(max_diff, float(np.abs(finals["nav_bias"] - finals["nav_bias_pinv"]).max()))
    mean = {k: float(np.mean(v)) for k, v in cpu.items()}
    return {
        "cpu_s_mean": mean,
        "ratio_nav_bias_over_plain": mean["nav_bias"] / mean["plain"],
        "ratio_nav_bias_pinv_over_plain": mean["nav_bias_pinv"] / mean["plain"],
        "max_abs_diff_solve_vs_pinv": max_diff,
    }


def _reference_cpu_in(tree: str, runs: int) -> list[float]:
    """CPU seconds per dense-loop run of the reference-preset AEKF as another checkout's
    own code runs it (a subprocess with ``tree`` first on the path; same seeds, so the same
    simulated data)."""
    code = (
        "import json\n"
        "from slam.experiments import get_experiment, run_once\n"
        "spec = get_experiment('dense-loop')\n"
        f"print(json.dumps([run_once(spec, 'aekf', r, {{'preset': 'reference'}}).cpu_s "
        f"for r in range({runs})]))\n"
    )
    return [float(v) for v in json_from_tree(tree, code, "AEKF run")]


def _cpu_ratio(d: dict) -> float:
    """FastSLAM 2.0 / AEKF ratio of CPU times (less sensitive to load than wall time)."""
    e = d["estimators"]
    return e["fastslam2"]["cpu_s_mean"] / e["aekf"]["cpu_s_mean"]


def _scaling(sizes, n_steps: int, seed: int = 0) -> dict:
    """Time of one scan cycle of AEKFSlam with n landmarks already in the map."""
    from slam.estimators.aekf import AEKFSlam

    rng = np.random.default_rng(seed)
    R = np.diag([0.1**2, np.radians(1.0) ** 2])
    Q = np.diag([0.02**2, 0.005**2, np.radians(0.3) ** 2])
    rows = []
    for n in sizes:
        # n landmarks on a grid with 4 m spacing around the origin; covariance PSD by
        # construction (diagonal + low rank), as a filter after many updates would have
        side = int(np.ceil(np.sqrt(n)))
        g = np.stack(np.meshgrid(np.arange(side), np.arange(side)), -1).reshape(-1, 2)[:n] * 4.0
        lm = g - g.mean(axis=0)
        N = 3 + 2 * n
        U = rng.standard_normal((N, 8)) * 0.05
        P = U @ U.T + np.diag(np.full(N, 0.01))
        f = AEKFSlam(x0=np.zeros(3))
        f.x = np.concatenate([np.zeros(3), lm.reshape(-1)])
        f.P = P
        f._lm_first = lm.copy()
        f.labels = np.full(n, -1, np.int64)
        f.ids = np.arange(n)
        f.misses = np.zeros(n, np.int64)
        f.hits = np.ones(n, np.int64)
        f._next_id = n
        dist = np.hypot(*lm.T)
        near = np.flatnonzero((dist > 5.0) & (dist < 10.0))[:2]  # two landmarks in view
        times, cpus, correct = [], [], []
        for _ in range(n_steps):
            d = lm[near] - f.x[:2]
            z = np.stack([np.hypot(*d.T), np.arctan2(d[:, 1], d[:, 0]) - f.x[2]], 1)
            z += rng.standard_normal(z.shape) * [0.1, np.radians(1.0)]
            t0, c0 = time.perf_counter(), time.process_time()
            f.predict_arrays([0.0, 0.0, 0.0], Q)
            res = f.update_arrays(z, R)
            times.append(time.perf_counter() - t0)
            cpus.append(time.process_time() - c0)
            correct.append(bool(np.all(res.associations == near)))
            if f.n_landmarks != n:  # an observation beyond the augment gate: undo, keep n fixed
                f.x, f.P = f.x[:N].copy(), f.P[:N, :N].copy()
                for name in ("_lm_first", "labels", "ids", "misses", "hits"):
                    setattr(f, name, getattr(f, name)[:n])
        t = float(np.median(times))
        tc = float(np.median(cpus))
        rows.append(
            {
                "n_landmarks": int(n),
                "state_dim": int(N),
                "scan_update_ms": 1e3 * t,
                "updates_per_s": 1.0 / t,
                "scan_update_cpu_ms": 1e3 * tc,
                "updates_per_cpu_s": 1.0 / tc if tc > 0 else float("inf"),
                "fraction_associated_correctly": float(np.mean(correct)),
            }
        )
    ns = np.array([r["n_landmarks"] for r in rows], float)
    ts = np.array([r["scan_update_ms"] for r in rows])
    slope = float(np.polyfit(np.log(ns), np.log(ts), 1)[0]) if len(rows) > 1 else float("nan")
    # between the two largest sizes the O(n²) pass over P dominates the fixed per-call cost
    last = (
        float(np.log(ts[-1] / ts[-2]) / np.log(ns[-1] / ns[-2])) if len(rows) > 1 else float("nan")
    )
    return {
        "rows": rows,
        "loglog_slope": slope,
        "loglog_slope_largest_two": last,
        "goal": "2000 landmarks at >= 50 updates/s",
    }


def _large_map(length_m: float, spacing_m: float, rng):
    """A straight survey line of ``length_m`` with landmarks every ``spacing_m`` on
    alternating sides at |y| in [5, 20] m: ``2 * length / spacing / 2`` landmarks."""
    xs = np.arange(10.0, length_m - 10.0, spacing_m)
    side = np.where(np.arange(xs.size) % 2 == 0, 1.0, -1.0)
    lm = np.stack([xs, side * rng.uniform(5.0, 20.0, xs.size)], axis=1)
    wp = np.stack([np.linspace(length_m / 4, length_m, 4), np.zeros(4)], axis=1)
    return lm, wp


def _submap_run(length_m: float, spacing_m: float, max_landmarks: int, full: bool) -> dict:
    """Sub-mapping AEKF (and optionally the full AEKF) along a long line with many
    landmarks: total estimator time and the update rate over the last 10 % of scans."""
    from slam.estimators.aekf import AEKFSlam
    from slam.estimators.aekf_submap import SubmapAEKFSlam
    from slam.metrics import landmark_errors
    from slam.sim2d import Sim2DConfig, simulate_run

    rng = np.random.default_rng(0)
    lm, wp = _large_map(length_m, spacing_m, rng)
    run = simulate_run(lm, wp, Sim2DConfig(n_loops=1), rng)
    out = {"length_m": length_m, "n_true_landmarks": int(lm.shape[0]), "n_scans": run.n_scans}
    variants = [("submap", lambda: SubmapAEKFSlam(max_landmarks=max_landmarks, jacobians="fej"))]
    if full:
        variants.append(("full", lambda: AEKFSlam(jacobians="fej")))
    for name, make in variants:
        f = make()
        times = np.empty(run.n_scans)
        for i in range(run.n_scans):
            z, lab = run.scan(i)
            t0 = time.perf_counter()
            f.predict_arrays(run.odom_u[i], run.odom_Q[i])
            f.update_arrays(z, run.R, lab)
            times[i] = time.perf_counter() - t0
        est, _ = f.landmarks()
        tail = times[-max(1, run.n_scans // 10) :]
        out[name] = {
            "total_s": float(times.sum()),
            "last10pct_updates_per_s": float(1.0 / np.mean(tail)),
            "n_landmarks": int(est.shape[0]),
            "landmark_rmse_m": landmark_errors(est, lm, est_labels=f.labels).rmse,
        }
        if name == "submap":
            out[name]["n_submaps"] = f.n_submaps
            out[name]["max_landmarks"] = max_landmarks
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="undersea bench slam", description=__doc__.split("\n")[0])
    p.add_argument("--json", action="store_true")
    p.add_argument("--runs", type=int, default=1, help="dense-loop runs per estimator (default 1)")
    p.add_argument("--sizes", default="100,500,2000", help="landmark counts for the scaling part")
    p.add_argument("--steps", type=int, default=20, help="timed scans per size (median reported)")
    p.add_argument("--skip-fastslam", action="store_true")
    p.add_argument("--skip-isam2", action="store_true")
    p.add_argument(
        "--skip-nav-bias", action="store_true", help="skip the navigation-bias-state timing"
    )
    p.add_argument("--blas-threads", type=int, default=1)
    p.add_argument("--submap-length", type=float, default=5000.0, help="m of survey line")
    p.add_argument("--submap-spacing", type=float, default=5.0, help="m between landmarks")
    p.add_argument("--submap-size", type=int, default=100, help="landmarks per local map")
    p.add_argument("--submap-full", action="store_true", help="also run the full AEKF on it")
    p.add_argument(
        "--against",
        default=None,
        metavar="TREE",
        help="another checkout (e.g. the round's start): its reference preset's CPU time "
        "per dense-loop run, for reading (b) consistent (this tree) / reference (TREE)",
    )
    p.add_argument(
        "--bailey-dir",
        default=os.environ.get("UNDERSEA_BAILEY_DIR"),
        help="directory of Bailey's ekfslam_v1 for the Octave comparison",
    )
    args = p.parse_args(argv)
    if args.against is not None and not os.path.isdir(os.path.join(args.against, "slam")):
        print(
            f"--against {args.against!r}: not a checkout of this project (no slam/)",
            file=sys.stderr,
        )
        return 2
    from threadpoolctl import threadpool_limits

    sizes = [int(s) for s in args.sizes.split(",") if s]
    load_start = os.getloadavg()
    result = {"dense_loop": _dense_loop_times(args.runs, args.skip_fastslam, args.skip_isam2)}
    d = result["dense_loop"]
    if args.against is not None and "cpu_s_mean" in d["estimators"].get("aekf-consistent", {}):
        ref_cpu = _reference_cpu_in(args.against, args.runs)
        d["against"] = {
            "tree": os.path.abspath(args.against),
            "reference_cpu_s": ref_cpu,
            "ratio_consistent_over_against_reference_cpu": d["estimators"]["aekf-consistent"][
                "cpu_s_mean"
            ]
            / float(np.mean(ref_cpu)),
        }
    if not args.skip_nav_bias:
        result["nav_bias"] = _nav_bias_times(1)
    oct_ = _octave_bailey(args.bailey_dir)
    if "time_s" in oct_:
        oct_["ratio_over_aekf"] = (
            oct_["time_s"] / result["dense_loop"]["estimators"]["aekf-consistent"]["time_s_mean"]
        )
    result["octave_bailey_ekfslam_v1"] = oct_
    if not args.skip_fastslam:  # the thesis's second cost comparison: the line map
        result["line"] = _dense_loop_times(args.runs, False, True, "line", full=False)
    result["load_average_1_5_15"] = {"start": load_start, "end": os.getloadavg()}
    with threadpool_limits(limits=args.blas_threads, user_api="blas"):
        result["scaling"] = _scaling(sizes, args.steps)
        result["submaps"] = _submap_run(
            args.submap_length, args.submap_spacing, args.submap_size, args.submap_full
        )
    result["scaling"]["blas_threads"] = args.blas_threads
    if args.json:
        print(json.dumps(result))
        return 0
    d = result["dense_loop"]
    print(
        f"dense loop, 2 loops, {d['n_scans']} scans, {d['runs']} run(s); simulation {d['simulation_s_mean']:.3f} s"
    )
    for name, e in d["estimators"].items():
        if "error" in e:
            print(f"  {name:10s} unavailable: {e['error']}")
        else:
            print(
                f"  {name:10s} {e['time_s_mean']:8.3f} s wall ({e['cpu_s_mean']:.3f} s CPU) per run   "
                f"landmark RMSE median {e['landmark_rmse_median_m']:.2f} m"
            )
    if "ratio_fastslam2_over_aekf" in d:
        print(
            f"  FastSLAM 2.0 / AEKF time ratio {d['ratio_fastslam2_over_aekf']:.1f} wall, "
            f"{_cpu_ratio(d):.1f} CPU "
            f"(reference MATLAB {d['reference_matlab_s']['ratio']:.2f}); AEKF target <= 1 s"
        )
    if "ratio_isam2_over_aekf" in d:
        print(f"  iSAM2 / AEKF time ratio {d['ratio_isam2_over_aekf']:.1f} wall")
    if "ratio_consistent_over_reference_cpu" in d:
        la = os.getloadavg()[0]
        print(
            f"  (a) AEKF consistent / reference preset, this tree: "
            f"{d['ratio_consistent_over_reference_cpu']:.2f}x CPU "
            f"(goal <= {d['goal_consistent_over_reference']:.1f}; load average {la:.1f})"
        )
        if "against" in d:
            ag = d["against"]
            print(
                f"  (b) AEKF consistent (this tree, {d['estimators']['aekf-consistent']['cpu_s_mean']:.3f} s) "
                f"/ reference preset of {ag['tree']} ({np.mean(ag['reference_cpu_s']):.3f} s): "
                f"{ag['ratio_consistent_over_against_reference_cpu']:.2f}x CPU "
                f"(goal <= {d['goal_consistent_over_reference']:.1f}; load average {la:.1f})"
            )
    if "nav_bias" in result:
        nbr = result["nav_bias"]
        c = nbr["cpu_s_mean"]
        print(
            f"  NavBiasSlam (consistent AEKF + 9 navigation bias states), one dense-loop run: "
            f"{c['nav_bias']:.3f} s CPU = {nbr['ratio_nav_bias_over_plain']:.2f}x the AEKF alone "
            f"({c['plain']:.3f} s); with the pseudo-inverse regression it replaced "
            f"{c['nav_bias_pinv']:.3f} s = {nbr['ratio_nav_bias_pinv_over_plain']:.2f}x; "
            f"largest difference of the two paths' final bias / pose "
            f"{nbr['max_abs_diff_solve_vs_pinv']:.1e}"
        )
    ob = result["octave_bailey_ekfslam_v1"]
    if "time_s" in ob:
        print(
            f"  Bailey's ekfslam_v1 in GNU Octave: {ob['time_s']:.2f} s per run "
            f"({ob['control_steps']} steps) = {ob['ratio_over_aekf']:.1f} x the AEKF "
            "(preset=consistent); target >= 25"
        )
    else:
        print(f"  Bailey's ekfslam_v1 in GNU Octave: not measured: {ob['error']}")
    if "line" in result:
        ln = result["line"]
        for name, e in ln["estimators"].items():
            if "time_s_mean" in e:
                print(
                    f"line map, {ln['n_scans']} scans: {name:10s} {e['time_s_mean']:8.3f} s wall "
                    f"({e['cpu_s_mean']:.3f} s CPU) per run"
                )
        if "ratio_fastslam2_over_aekf" in ln:
            print(
                f"  FastSLAM 2.0 / AEKF time ratio {ln['ratio_fastslam2_over_aekf']:.1f} wall, "
                f"{_cpu_ratio(ln):.1f} CPU (reference MATLAB {ln['reference_matlab_s']['ratio']:.2f})"
            )
    la = result["load_average_1_5_15"]
    print(
        "load average (1, 5, 15 min) at start "
        + ", ".join(f"{v:.1f}" for v in la["start"])
        + "; at end "
        + ", ".join(f"{v:.1f}" for v in la["end"])
        + " on "
        + str(os.cpu_count())
        + " CPUs (ratios are measured in one run; wall times scale with load)"
    )
    s = result["scaling"]
    print(
        f"AEKF scan update (predict + association over all landmarks + batch update of 2), BLAS threads {args.blas_threads}:"
    )
    for r in s["rows"]:
        print(
            f"  n = {r['n_landmarks']:5d} (state {r['state_dim']:5d}): {r['scan_update_ms']:8.3f} ms "
            f"= {r['updates_per_s']:8.1f} updates/s wall ({r['updates_per_cpu_s']:.1f} per CPU s); "
            f"{100 * r['fraction_associated_correctly']:.0f} % of scans fully associated"
        )
    print(
        f"  log-log slope {s['loglog_slope']:.2f} overall, {s['loglog_slope_largest_two']:.2f} between "
        f"the two largest sizes (2 = O(n²); small maps pay a fixed per-call cost); goal {s['goal']}"
    )
    m = result["submaps"]
    print(
        f"sub-mapping AEKF on a {m['length_m']:.0f} m line with {m['n_true_landmarks']} landmarks, "
        f"{m['n_scans']} scans:"
    )
    for name in ("submap", "full"):
        if name in m:
            e = m[name]
            extra = (
                f", {e['n_submaps']} local maps of <= {e['max_landmarks']}"
                if name == "submap"
                else ""
            )
            print(
                f"  {name:6s}: {e['total_s']:.2f} s total, {e['last10pct_updates_per_s']:.0f} updates/s "
                f"over the last 10 %, {e['n_landmarks']} landmarks, RMSE {e['landmark_rmse_m']:.2f} m{extra}"
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

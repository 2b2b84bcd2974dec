"""The reference's simulated SLAM experiments (thesis ch. 6) on Bailey's simulator.

``EXPERIMENTS`` holds the three: ``dense-loop`` (``example_webmap``, two loops),
``line`` (1000 m line map, one pass) and ``segmentation-loop`` (54 segmentation
landmarks, two loops as Bailey's default). :func:`run_once` drives one estimator through one seeded run and
measures it; :func:`run_monte_carlo` repeats with seeds ``seed, seed + 1, ...`` and adds
the average NEES with its χ² bounds and the NIS.

An estimator is predicted once per observation scan with the odometry of that interval
(the per-step increments composed; exact for the EKF, see
:func:`slam.sim2d.compose_increments`) and updated with the scan's observations (labels
carried for known-answer evaluation; an estimator ignores them unless configured for
known association).
"""

from __future__ import annotations

import math
import os
import sys
import time
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from slam.data.reference_maps import ReferenceMap
from slam.estimators import make_estimator
from slam.metrics import (
    average_nees,
    chi2_bounds,
    fraction_inside,
    landmark_errors,
    landmark_mahalanobis,
    named_landmark_errors,
    nees,
    pose_error,
    trajectory_rmse,
)
from slam.sim2d import (
    DENSE_LOOP_LANDMARKS_AB,
    Sim2DConfig,
    Sim2DRun,
    dense_loop_map,
    line_map,
    segmentation_loop_map,
    simulate_run,
)
from slam.sim2d.maps import LINE_LANDMARKS_ABCD, SEGMENTATION_CENTROIDS

__all__ = [
    "EXPERIMENTS",
    "ExperimentSpec",
    "MonteCarloResult",
    "RunResult",
    "get_experiment",
    "run_monte_carlo",
    "run_once",
    "save_results",
    "with_loops",
]


@dataclass(frozen=True)
class ExperimentSpec:
    """One experiment: ``map`` (landmarks, waypoints), simulator ``sim`` config and the
    named true landmarks whose errors the thesis tabulates."""

    name: str
    map: ReferenceMap
    sim: Sim2DConfig
    named: dict = field(default_factory=dict)


def _named(points, letters="ABCDEFGH"):
    return {letters[i]: tuple(map(float, p)) for i, p in enumerate(points)}


def _segmentation_named():
    out = {}
    for kind, pts in SEGMENTATION_CENTROIDS.items():
        for i, p in enumerate(pts):
            out[f"{kind}{i + 1}"] = tuple(map(float, p))
    return out


def get_experiment(
    name: str, *, dt: float = 0.025, n_loops: int | None = None, unbiased_odometry: bool = False
) -> ExperimentSpec:
    """Build experiment ``name`` ("dense-loop", "line", "segmentation-loop") with control
    interval ``dt`` s (0.025 Bailey's default, 0.0125 the thesis's) and optionally another
    number of loops; ``unbiased_odometry`` see :class:`slam.sim2d.Sim2DConfig`."""
    if name not in EXPERIMENTS:
        raise ValueError(f"unknown experiment {name!r}; allowed: {', '.join(EXPERIMENTS)}")
    if not (math.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be > 0 s, got {dt}")
    maker, loops, named = EXPERIMENTS[name]
    sim = Sim2DConfig(
        dt_s=dt, n_loops=loops if n_loops is None else n_loops, unbiased_odometry=unbiased_odometry
    )
    return ExperimentSpec(name, maker(), sim, named())


#: AEKF options the 2-D experiments add to the default (``consistent``) preset: delayed
#: confirmation of new landmarks, whose misses are counted on the AEKF's forward half-disc
#: footprint, which is exactly this simulator's sensor (not the 3-D scenarios' sonars, so
#: it is not in the preset); ``--param provisional_misses=null`` turns it off. Measured in
#: slam/experiments/README.md ("Delayed confirmation").
EXPERIMENT_AEKF_DEFAULTS: dict = {"provisional_misses": 3}

#: name -> (map factory, number of loops, named landmarks)
EXPERIMENTS = {
    "dense-loop": (dense_loop_map, 2, lambda: _named(DENSE_LOOP_LANDMARKS_AB)),
    "line": (line_map, 1, lambda: _named(LINE_LANDMARKS_ABCD)),
    "segmentation-loop": (segmentation_loop_map, 2, _segmentation_named),
}


@dataclass(frozen=True)
class RunResult:
    """One run. Errors in m; ``nees (S,)`` vehicle-pose NEES after each scan's update;
    ``nis (K,)`` NIS of every associated observation; ``time_s`` wall time of the
    estimator's predict/update calls only; ``cpu_s`` process CPU time of the whole
    estimator loop (less sensitive to a loaded machine). Arrays for figures: ``est_poses (S, 3)``,
    ``true_poses (S, 3)``, ``pose_cov (S, 3, 3)``, ``lm_est (m, 2)``, ``lm_cov (m, 2, 2)``, ``lm_labels (m,)`` the
    simulator label each landmark was created from (estimators that keep it; else None)."""

    seed: int
    filter: str
    landmark_rmse: float
    named_errors: dict
    ate: float
    heading_rmse: float
    time_s: float
    cpu_s: float
    n_landmarks: int
    n_true_seen: int
    n_duplicates: int
    n_missed: int
    frac_in_3sigma: float
    nees: np.ndarray
    nis: np.ndarray
    est_poses: np.ndarray
    true_poses: np.ndarray
    pose_cov: np.ndarray
    lm_est: np.ndarray
    lm_cov: np.ndarray
    lm_labels: np.ndarray | None = None

    def summary(self) -> dict:
        """JSON-friendly scalars."""
        d = {k: v for k, v in asdict(self).items() if not isinstance(v, np.ndarray)}
        d["mean_nees"] = float(np.nanmean(self.nees)) if self.nees.size else float("nan")
        d["mean_nis"] = float(np.mean(self.nis)) if self.nis.size else float("nan")
        return d


def run_once(
    spec: ExperimentSpec,
    filter_name: str = "aekf",
    seed: int = 0,
    estimator_params: dict | None = None,
    *,
    sim_run: Sim2DRun | None = None,
    blas_threads: int | None = 1,
) -> RunResult:
    """Simulate run ``seed`` of ``spec`` (or use ``sim_run``) and drive ``filter_name``.

    The simulation draws from ``default_rng(seed)``; the estimator gets its own generator
    spawned from it (FastSLAM's sampling), so the data are the same for every estimator.
    ``blas_threads`` limits BLAS threads while the estimator runs (None: no limit): the
    filters' matrices are small, and oversubscribed BLAS threads on a shared machine make
    them ten times slower.
    """
    if blas_threads is None:
        return _run_once(spec, filter_name, seed, estimator_params, sim_run)
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=blas_threads, user_api="blas"):
        return _run_once(spec, filter_name, seed, estimator_params, sim_run)


def _run_once(spec, filter_name, seed, estimator_params, sim_run) -> RunResult:
    ss = np.random.SeedSequence(seed)
    sim_seed, est_seed = ss.spawn(2)
    run = sim_run or simulate_run(
        spec.map.landmarks, spec.map.waypoints, spec.sim, np.random.default_rng(sim_seed)
    )
    params = dict(estimator_params or {})
    if filter_name == "aekf" and params.get("preset", "consistent") == "consistent":
        params = {**EXPERIMENT_AEKF_DEFAULTS, **params}
    params.setdefault("rng", np.random.default_rng(est_seed))
    est = make_estimator(filter_name, **params)
    S = run.n_scans
    odo = [run.odometry(i) for i in range(S)]
    obs = [run.observations(i) for i in range(S)]
    est_poses = np.empty((S, 3))
    pose_cov = np.empty((S, 3, 3))
    nis_all = []
    elapsed = 0.0
    cpu0 = time.process_time()
    for i in range(S):
        t0 = time.perf_counter()
        est.predict(odo[i])
        res = est.update(obs[i])
        elapsed += time.perf_counter() - t0
        est_poses[i], pose_cov[i] = est.pose()
        nis_all.append(res.nis[np.isfinite(res.nis)])
    t0 = time.perf_counter()
    lm_est, lm_cov = est.landmarks()
    elapsed += time.perf_counter() - t0
    cpu = time.process_time() - cpu0  # includes the loop's bookkeeping (est.pose() etc.)
    err = pose_error(run.true_poses, est_poses)
    ne = nees(err, pose_cov)
    labels = getattr(est, "labels", None)
    if labels is not None and np.asarray(labels).shape != (lm_est.shape[0],):
        labels = None
    if labels is not None and filter_name not in ("aekf", "aekf-submap", "aekf-robocentric"):
        labels = None
    # labels when the estimator keeps them; else a one-to-one assignment gated at 50 m
    # (the line map's errors reach tens of metres; a tight gate would hide them), against
    # the landmarks that were ever observed: a never-seen one cannot have an estimate, and
    # matching a duplicate to it would hide the duplicate
    seen_idx = np.unique(run.obs_label)
    true_seen = run.landmarks[seen_idx]
    seen_labels = None
    if labels is not None:
        pos = np.full(run.landmarks.shape[0], -1, dtype=np.int64)
        pos[seen_idx] = np.arange(seen_idx.size)
        seen_labels = np.where(np.asarray(labels) >= 0, pos[np.asarray(labels)], -1)
    le = landmark_errors(lm_est, true_seen, est_labels=seen_labels, max_distance=50.0)
    seen = seen_idx.size
    md = landmark_mahalanobis(lm_est[le.est_index], lm_cov[le.est_index], true_seen[le.true_index])
    ate, hr = trajectory_rmse(run.true_poses, est_poses)
    return RunResult(
        seed=seed,
        filter=filter_name,
        landmark_rmse=le.rmse,
        named_errors=named_landmark_errors(le, lm_est, true_seen, spec.named),
        ate=ate,
        heading_rmse=hr,
        time_s=elapsed,
        cpu_s=cpu,
        n_landmarks=int(lm_est.shape[0]),
        n_true_seen=int(seen),
        n_duplicates=int(le.n_unmatched_est),
        n_missed=int(seen - le.true_index.size),
        frac_in_3sigma=float(np.mean(md <= 3.0)) if md.size else float("nan"),
        nees=ne,
        nis=np.concatenate(nis_all) if nis_all else np.zeros(0),
        est_poses=est_poses,
        true_poses=run.true_poses,
        pose_cov=pose_cov,
        lm_est=lm_est,
        lm_cov=lm_cov,
        lm_labels=None if labels is None else np.asarray(labels).copy(),
    )


@dataclass(frozen=True)
class MonteCarloResult:
    """N runs of one experiment and estimator: per-run results, ``avg_nees (S,)`` and its
    95 % bounds for n = 3, the fraction of scans where it lies inside, the overall NIS
    average (dof 2) and its bounds."""

    experiment: str
    filter: str
    runs: list
    avg_nees: np.ndarray
    nees_bounds: tuple
    nees_frac_inside: float
    mean_nis: float
    nis_bounds: tuple
    params: dict

    def summary(self) -> dict:
        arr = lambda key: np.array([getattr(r, key) for r in self.runs], dtype=float)  # noqa: E731
        med = lambda a: float(np.nanmedian(a)) if np.isfinite(a).any() else float("nan")  # noqa: E731
        names = list(self.runs[0].named_errors) if self.runs else []
        nmean = lambda a: float(np.nanmean(a)) if np.isfinite(a).any() else float("nan")  # noqa: E731
        return {
            "experiment": self.experiment,
            "filter": self.filter,
            "params": {k: v for k, v in self.params.items() if k != "rng"},
            "n_runs": len(self.runs),
            "landmark_rmse_median_m": med(arr("landmark_rmse")),
            "landmark_rmse_mean_m": nmean(arr("landmark_rmse")),
            "named_errors_median_m": {
                k: med(np.array([r.named_errors[k] for r in self.runs])) for k in names
            },
            "ate_median_m": med(arr("ate")),
            "time_s_mean": float(np.mean(arr("time_s"))),
            "frac_in_3sigma": nmean(arr("frac_in_3sigma")),
            "runs_with_duplicates": int(np.sum(arr("n_duplicates") > 0)),
            "avg_nees_time_mean": nmean(self.avg_nees),
            "nees_bounds": list(self.nees_bounds),
            "nees_frac_inside": self.nees_frac_inside,
            "mean_nis": self.mean_nis,
            "nis_bounds": list(self.nis_bounds),
            "runs": [r.summary() for r in self.runs],
        }


def _progress(total: int, desc: str, enabled: bool | None):
    if enabled is None:
        enabled = sys.stderr.isatty() and os.environ.get("CI", "").lower() not in ("1", "true")
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, disable=not enabled, leave=False)


def run_monte_carlo(
    spec: ExperimentSpec,
    filter_name: str = "aekf",
    runs: int = 10,
    seed: int = 0,
    estimator_params: dict | None = None,
    *,
    progress: bool | None = None,
) -> MonteCarloResult:
    """``runs`` seeded runs (seeds ``seed .. seed + runs - 1``) and their statistics."""
    if runs < 1:
        raise ValueError(f"runs must be >= 1, got {runs}")
    results = []
    with _progress(runs, f"{spec.name} {filter_name}", progress) as bar:
        for r in range(runs):
            results.append(run_once(spec, filter_name, seed + r, estimator_params))
            bar.update(1)
    A = np.stack([r.nees for r in results])
    avg = average_nees(A)
    bounds = chi2_bounds(3, runs)
    nis = np.concatenate([r.nis for r in results])
    nis_b = chi2_bounds(2, max(nis.size, 1))
    return MonteCarloResult(
        experiment=spec.name,
        filter=filter_name,
        runs=results,
        avg_nees=avg,
        nees_bounds=bounds,
        nees_frac_inside=fraction_inside(avg, bounds),
        mean_nis=float(np.mean(nis)) if nis.size else float("nan"),
        nis_bounds=nis_b,
        params=dict(estimator_params or {}),
    )


def with_loops(spec: ExperimentSpec, n_loops: int) -> ExperimentSpec:
    """The same experiment with another number of loops (e.g. 1 for a short CI variant)."""
    return replace(spec, sim=replace(spec.sim, n_loops=n_loops))


def save_results(mc: MonteCarloResult, spec: ExperimentSpec, out_dir) -> dict:
    """Write ``results.json``, ``map.png`` (first run) and ``nees.png`` to ``out_dir``;
    return the summary dict (with the file names)."""
    import json
    from pathlib import Path

    from slam.experiments.figures import plot_map, plot_nees

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    summary = mc.summary()
    stem = f"{spec.name}_{mc.filter}"
    files = {
        "map": str(
            plot_map(
                mc.runs[0],
                spec.map.landmarks,
                spec.map.waypoints,
                out / f"{stem}_map.png",
                title=f"{spec.name}, {mc.filter}, seed {mc.runs[0].seed}: landmark RMSE "
                f"{mc.runs[0].landmark_rmse:.2f} m",
                named=spec.named,
            )
        ),
        "nees": str(
            plot_nees(
                mc.avg_nees,
                mc.nees_bounds,
                out / f"{stem}_nees.png",
                t=(np.arange(mc.avg_nees.size) + 1) * spec.sim.dt_observe,
                runs=len(mc.runs),
            )
        ),
    }
    summary["files"] = files
    summary["dt_s"] = spec.sim.dt_s
    summary["n_loops"] = spec.sim.n_loops
    summary["unbiased_odometry"] = spec.sim.unbiased_odometry
    (out / f"{stem}_results.json").write_text(json.dumps(_jsonable(summary), indent=2))
    return summary


def _jsonable(o):
    if isinstance(o, dict):
        return {str(k): _jsonable(v) for k, v in o.items()}
    if isinstance(o, list | tuple):
        return [_jsonable(v) for v in o]
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, float) and not math.isfinite(o):
        return None
    return o

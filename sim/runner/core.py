"""Headless scenario runs: build (sim.runner.build), run (sim.runner.schedule), record
(sim.runner.log), score (sim.runner.score), figures (sim.runner.figures).

Outputs (:func:`run_scenario`): ``DIR/recording.rrd`` (sim.viz.rerun_log), ``DIR/metrics.json``
(sim.runner.metrics; ``"complete": false`` after Ctrl-C), ``DIR/trajectory_map.png`` and
``DIR/sss_mosaic.png``. The directory is staged and renamed at the end (sim.runner.output).
Everything in metrics.json except its ``"timing"`` section (wall-clock: per-stage seconds
and the real-time factor) depends only on the scenario and the seed.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sim.runner.figures import write_figures
from sim.runner.fleet import fleet_map
from sim.runner.log import RerunObserver
from sim.runner.output import RunDirectory, discard_partial_on_error
from sim.runner.progress import make_progress
from sim.runner.schedule import ScenarioRun
from sim.runner.score import vehicle_metrics
from sim.scenario.schema import Scenario
from sim.viz import rerun_log as L


@dataclass
class RunResult:
    out_dir: Path
    metrics: dict
    complete: bool

    def summary(self) -> str:
        m = self.metrics
        lines = [f"run {'complete' if self.complete else 'INTERRUPTED'}: {self.out_dir}"]
        for name, v in m.get("vehicles", {}).items():
            lm, po, de = v.get("landmarks", {}), v.get("pose", {}), v.get("detections", {})
            inside = po.get("nees_in_95_interval")
            lines.append(
                f"  {name}: ATE SLAM {_fmt(po.get('ate_m'))} m vs dead reckoning "
                f"{_fmt(po.get('dead_reckoning_ate_m'))} m, pose NEES {_fmt(po.get('nees_mean'))}"
                f" ({'n/a' if inside is None else f'{100 * inside:.0f} %'} inside 95 %), "
                f"landmarks {lm.get('n_estimated', 0)} (RMSE {_fmt(lm.get('rmse_m'))} m, "
                f"NEES {_fmt(lm.get('landmark_nees_mean'))}, "
                f"duplicated {lm.get('n_duplicated_objects', 0)}), "
                f"detections {de.get('n_detections', 0)} (PPV {_fmt(de.get('ppv'))})"
            )
            for w in v.get("navigation", {}).get("warnings", []):
                lines.append(f"  WARNING {name}: {w}")
        fl = m.get("fleet")
        if fl:
            lm = fl["landmarks"]
            gps = ", ".join(fl["gps_anchored"]) or "none"
            lines.append(
                f"  fleet map ({len(fl['vehicles'])} maps fused, "
                f"{fl['n_paired_between_vehicles']} landmarks paired between vehicles, "
                f"GPS anchors: {gps}): landmarks {lm.get('n_estimated', 0)} "
                f"(RMSE {_fmt(lm.get('rmse_m'))} m, NEES {_fmt(lm.get('landmark_nees_mean'))}, "
                f"duplicated {lm.get('n_duplicated_objects', 0)}, "
                f"spurious {lm.get('n_spurious', 0)}, "
                f"{lm.get('n_true_mapped', 0)} of {lm.get('n_objects_imaged', 0)} imaged objects)"
            )
        t = m.get("timing", {})
        lines.append(
            f"  sim {m.get('sim_time_s', 0):.1f} s in {_fmt(t.get('wall_s'))} s (RTF {_fmt(t.get('real_time_factor'))})"
        )
        return "\n".join(lines)


def _fmt(x) -> str:
    return "n/a" if x is None else f"{x:.3g}"


@discard_partial_on_error
def run_scenario(
    scenario: Scenario,
    out_dir: str | Path,
    *,
    overwrite: bool = False,
    progress: bool | None = None,
    stop_flag=None,
) -> RunResult:
    """Run a validated scenario headless and write its outputs to ``out_dir``.

    progress: tqdm bar with sim time, real-time factor and ETA on a terminal, a plain
    line every 5 s otherwise (default); False for none (sim.runner.progress).
    stop_flag: optional callable polled every tick; True stops the run as
    Ctrl-C does (used by tests). Returns the metrics and whether the run completed.
    """
    out = RunDirectory(out_dir, overwrite=overwrite)
    wall0 = time.perf_counter()
    rec = None
    if scenario.outputs.recording:
        bp = L.default_blueprint({v.name: [s.name for s in v.sonars] for v in scenario.vehicles})
        rec = L.open_recording(
            out.path("recording.rrd"),
            application_id="undersea",
            recording_id=f"{scenario.name}-seed{scenario.seed}",
            blueprint=bp,
        )
    observers = [RerunObserver(rec)] if rec is not None else []
    run = ScenarioRun(scenario, observers)
    for o in observers:
        o.on_start(run)
    bar = make_progress(scenario.name, scenario.duration_s, progress)
    cb = None if bar is None else bar.update
    complete = False
    error: BaseException | None = None
    try:
        complete = run.run(scenario.duration_s, progress=cb, stop_flag=stop_flag)
    except BaseException as exc:  # write what we have, marked incomplete, then re-raise
        error = exc
    finally:
        if bar is not None:
            bar.close()
    wall = time.perf_counter() - wall0
    metrics = {
        "scenario": scenario.name,
        "seed": scenario.seed,
        "complete": complete,
        "duration_s": scenario.duration_s,
        "sim_time_s": round(run.t_sim, 6),
        "vehicles": vehicle_metrics(run),
        "objects": [
            {
                "id": o.id,
                "class": o.class_name,
                "position": np.round(np.asarray(o.position), 4).tolist(),
            }
            for o in run.world.objects
        ],
        "timing": {
            "note": "wall-clock seconds; the only part of this file that varies between identical runs",
            "wall_s": wall,
            "real_time_factor": run.t_sim / wall if wall > 0 else None,
            "stages_s": dict(run.timer.s),
        },
    }
    fused = None
    if error is None:
        try:
            fused, fleet = fleet_map(run, inputs_to=out.path("fleet_maps.npz"))
        except Exception as exc:  # the fused map must not lose the vehicles' metrics
            fused, fleet = None, None
            metrics["fleet_error"] = f"{type(exc).__name__}: {exc}"
        if fleet is not None:
            metrics["fleet"] = fleet
    if error is not None:
        metrics["error"] = f"{type(error).__name__}: {error}"
    if not complete:
        metrics["interrupted_at_s"] = round(run.t_sim, 6)
    if rec is not None:
        if fused is not None:
            L.set_time(rec, run.world.time)
            z = run.world.seabed_height(fused.landmarks) + 0.5 if fused.n_landmarks else 0.0
            L.log_landmarks(rec, "fleet", fused.landmarks, fused.landmark_cov, z)
            lm = metrics["fleet"]["landmarks"]
            L.log_scalars(
                rec,
                "fleet",
                {
                    "landmark_rmse_m": lm.get("rmse_m"),
                    "n_landmarks": float(fused.n_landmarks),
                    "n_duplicated": float(lm.get("n_duplicated_objects", 0)),
                },
            )
        L.close_recording(rec)
    if scenario.outputs.figures:
        try:
            write_figures(run, out)
        except Exception as exc:  # figures must not lose the run's data
            metrics["figures_error"] = f"{type(exc).__name__}: {exc}"
    out.write_json("metrics.json", metrics)
    final = out.finalize()
    if error is not None and not isinstance(error, KeyboardInterrupt):
        raise error
    return RunResult(final, metrics, complete)

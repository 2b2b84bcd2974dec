"""Sweeps: parallel equals serial run by run, resume, failures recorded, a killed worker
loses no finished run, aggregation against hand-computed statistics and the published
chi-square bounds."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from sim.sweep import SweepPlan, aggregate_runs, nees_consistency, parse_vary, run_sweep
from sim.sweep.runner import load_records

# one loop of the dense-loop map at dt 0.025: about a second per run
TARGET = "slam:dense-loop"
VARY = {"loops": [1]}


#: wall/CPU clock metrics: the only ones allowed to differ between identical runs
CLOCKS = ("time_s", "cpu_s", "wall_s")


def _metrics_by_run(out: Path) -> dict[str, dict]:
    recs = load_records(out)
    return {r["run_id"]: {k: v for k, v in r["metrics"].items() if k not in CLOCKS} for r in recs}


#: the plan both parallel tests (process pool, Ray) compare with its serial run
PARALLEL_PLAN = SweepPlan(TARGET, runs=3, vary=VARY, base_seed=5)


@pytest.fixture(scope="module")
def serial_metrics(tmp_path_factory) -> dict[str, dict]:
    """PARALLEL_PLAN run serially (one process), metrics by run id: the reference of the
    two-worker and the Ray test, made once."""
    out = tmp_path_factory.mktemp("serial")
    res = run_sweep(PARALLEL_PLAN, out, workers=1, progress=False)
    assert not res.failed and len(res.finished) == 3
    return _metrics_by_run(out)


def test_two_worker_sweep_equals_serial_run_by_run(serial_metrics, tmp_path):
    par = run_sweep(PARALLEL_PLAN, tmp_path / "par", workers=2, progress=False)
    assert not par.failed
    a, b = serial_metrics, _metrics_by_run(tmp_path / "par")
    assert sorted(a) == sorted(b) and len(a) == 3
    for run_id in a:
        assert a[run_id] == b[run_id], run_id
    # distinct seeds give distinct runs (the comparison above is not vacuous)
    rmses = {m["landmark_rmse"] for m in a.values()}
    assert len(rmses) == 3


def test_resume_skips_finished_runs(tmp_path):
    plan = SweepPlan(TARGET, runs=2, vary=VARY)
    first = run_sweep(plan, tmp_path, progress=False)
    assert first.finished == ["loops=1__seed1", "loops=1__seed2"]
    before = (tmp_path / "runs" / "loops=1__seed1.json").read_text()
    (tmp_path / "runs" / "loops=1__seed2.json").unlink()  # as if killed before run 2 ended
    second = run_sweep(plan, tmp_path, progress=False)
    assert second.skipped == ["loops=1__seed1"] and second.finished == ["loops=1__seed2"]
    assert (tmp_path / "runs" / "loops=1__seed1.json").read_text() == before


def test_resume_into_another_plan_stops_and_force_starts_over(tmp_path):
    """Issue 15: a second sweep with another target, variants or seeds into the same --out
    must not adopt the first sweep's runs; --force deletes them and starts over."""
    from sim.sweep import PlanMismatchError

    first = SweepPlan(TARGET, runs=1, vary=VARY)
    run_sweep(first, tmp_path, progress=False)
    plan_before = (tmp_path / "plan.json").read_text()
    for other in (
        SweepPlan("slam:line", runs=1, vary=VARY),  # another target
        SweepPlan(TARGET, runs=1, vary={"loops": [1], "filter": ["aekf"]}),  # variants
        SweepPlan(TARGET, runs=1, vary=VARY, base_seed=2),  # seeds
    ):
        with pytest.raises(PlanMismatchError, match="--force"):
            run_sweep(other, tmp_path, progress=False)
        assert (tmp_path / "plan.json").read_text() == plan_before
    # a new code version is another plan too
    assert first.plan_hash(code="0.1.0+gaaaa") != first.plan_hash(code="0.1.0+gbbbb")
    other = SweepPlan(TARGET, runs=1, vary=VARY, base_seed=2)
    res = run_sweep(other, tmp_path, progress=False, force=True)
    assert res.skipped == [] and res.finished == ["loops=1__seed2"]
    assert [r["run_id"] for r in load_records(tmp_path)] == ["loops=1__seed2"]
    assert json.loads((tmp_path / "plan.json").read_text())["base_seed"] == 2


def test_failed_run_is_recorded_with_seed_and_error(tmp_path):
    # est.* keys go to the estimator, which rejects an unknown one only when the run starts
    plan = SweepPlan(TARGET, runs=1, vary={"loops": [1], "est.bogus_gate": [1.0]}, base_seed=7)
    res = run_sweep(plan, tmp_path, progress=False)
    assert len(res.failed) == 1
    rec = json.loads(next((tmp_path / "failed").glob("*.json")).read_text())
    assert rec["seed"] == 7 and rec["status"] == "failed"
    assert "bogus_gate" in rec["error"] and "Traceback" in rec["traceback"]
    assert load_records(tmp_path) == []


def test_bad_variant_stops_before_anything_runs(tmp_path):
    """Issue 15: `sweep --vary bogus.key=1` named the key only in a failed run record."""
    with pytest.raises(ValueError, match="bogus"):
        run_sweep(SweepPlan(TARGET, runs=1, vary={"bogus": [1]}), tmp_path / "a")
    with pytest.raises(ValueError, match="'bogus'"):
        run_sweep(SweepPlan("shipwreck-survey", runs=1, vary={"bogus.key": [1]}), tmp_path / "b")
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()


def test_unknown_target_names_allowed_forms(tmp_path):
    with pytest.raises(ValueError, match="allowed: a scenario name"):
        run_sweep(SweepPlan("no-such-scenario", runs=1), tmp_path)
    with pytest.raises(ValueError, match="unknown experiment"):
        run_sweep(SweepPlan("slam:nope", runs=1), tmp_path)


def test_parse_vary():
    assert parse_vary(["filter=aekf,fastslam2", "dt=0.0125", "loops=1"]) == {
        "filter": ["aekf", "fastslam2"], "dt": [0.0125], "loops": [1]}
    for bad in ["filter", "=1", "a=", "x y=1"]:
        with pytest.raises(ValueError, match="--vary"):
            parse_vary([bad])


def test_killed_worker_loses_no_finished_run(tmp_path):
    """SIGKILL one worker after the first run finished: that run stays on disk unchanged,
    the lost run is resubmitted, and all runs end finished."""
    psutil = pytest.importorskip("psutil")
    out = tmp_path / "kill"
    cmd = [sys.executable, "-m", "sim.cli.main", "sweep", TARGET, "--runs", "4", "--vary",
           "loops=1", "--workers", "2", "--out", str(out)]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            env={**os.environ, "CI": "1"})
    runs = out / "runs"
    deadline = time.time() + 120
    while time.time() < deadline and not (runs.is_dir() and any(runs.glob("*.json"))):
        time.sleep(0.1)
    finished = {p.name: p.read_text() for p in runs.glob("*.json")}
    assert finished, "no run finished in time"
    workers = [c for c in psutil.Process(proc.pid).children(recursive=True)
               if "resource_tracker" not in " ".join(c.cmdline())]
    assert workers
    os.kill(workers[0].pid, signal.SIGKILL)
    proc.communicate(timeout=240)
    for name, text in finished.items():
        assert (runs / name).read_text() == text
    assert len(list(runs.glob("*.json"))) == 4, proc.returncode


def test_aggregate_matches_hand_computed_t_interval():
    vals = [1.0, 2.0, 4.0]
    recs = [{"status": "ok", "variant_id": "v", "metrics": {"a": {"b": v}, "s": "x"}} for v in vals]
    recs.append({"status": "failed", "variant_id": "v", "error": "boom"})
    row = aggregate_runs(recs).get("v", "a.b")
    m, s = np.mean(vals), np.std(vals, ddof=1)
    half = stats.t.ppf(0.975, 2) * s / np.sqrt(3)
    assert row["n"] == 3 and row["mean"] == pytest.approx(m) and row["std"] == pytest.approx(s)
    assert row["ci95_low"] == pytest.approx(m - half) and row["ci95_high"] == pytest.approx(m + half)


def test_nees_bounds_are_the_published_ones():
    """REFERENCE/issue: for n = 3 and 50 runs the 95 % bounds are [2.36, 3.72]."""
    rng = np.random.default_rng(0)
    recs = [{"status": "ok", "variant_id": "v",
             "metrics": {"nees_series": list(rng.chisquare(3, size=200))}} for _ in range(50)]
    c = nees_consistency(recs)["v"]
    assert c["bounds"] == pytest.approx([2.36, 3.72], abs=0.01)
    # chi-square(3) draws are consistent by construction: about 95 % of steps inside
    assert 0.85 < c["fraction_inside"] <= 1.0
    assert c["mean_nees"] == pytest.approx(3.0, abs=0.1)


def test_ray_local_two_workers_equals_serial(serial_metrics, tmp_path):
    """A local Ray started by the sweep (2 workers) gives the serial results run by run."""
    pytest.importorskip("ray")
    on_ray = run_sweep(PARALLEL_PLAN, tmp_path / "ray", workers=2, use_ray=True, progress=False)
    assert not on_ray.failed
    a, b = serial_metrics, _metrics_by_run(tmp_path / "ray")
    assert sorted(a) == sorted(b) and len(a) == 3
    for run_id in a:
        assert a[run_id] == b[run_id], run_id


def test_scenario_sweep_with_override_matches_a_direct_run(tmp_path):
    """A sweep run of a scenario equals the scenario runner called directly with the same
    overrides and seed (metrics except wall-clock timing), and a bad override stops the
    sweep before it runs, naming the field."""
    from sim.runner import run_scenario
    from sim.scenario import load_scenario

    plan = SweepPlan("shipwreck-survey", runs=1, vary={"duration_s": [4.0]}, base_seed=3)
    res = run_sweep(plan, tmp_path / "sw", progress=False)
    assert not res.failed, res.failed
    (rec,) = load_records(tmp_path / "sw")
    direct = run_scenario(load_scenario("shipwreck-survey", {"duration_s": 4.0}).with_overrides(seed=3),
                          tmp_path / "direct", progress=False).metrics
    for m in (rec["metrics"], direct):
        m.pop("timing"), m.pop("objects", None)
    assert rec["metrics"] == json.loads(json.dumps(direct))
    with pytest.raises(ValueError, match="duration_s"):
        run_sweep(SweepPlan("shipwreck-survey", runs=1, vary={"duration_s": [-1.0]}),
                  tmp_path / "bad", progress=False)
    assert not (tmp_path / "bad").exists()

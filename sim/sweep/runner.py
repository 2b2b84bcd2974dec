"""Execute a sweep plan serially, on local worker processes, or on a Ray cluster.

Each finished run is written by the worker itself, atomically, to
``OUT/runs/<run_id>.json`` the moment it finishes, so killing a worker (or the whole
sweep) loses no finished run, and running the same sweep again resumes: runs with a
result file are skipped. A run that raises is recorded in ``OUT/failed/<run_id>.json``
with its seed, variant and traceback — never silently dropped — and is tried again on the
next invocation. A run whose worker process dies is resubmitted on a fresh pool up to
``max_retries`` times, then recorded as failed.
"""

from __future__ import annotations

import json
import os
import sys
import time
import traceback
from dataclasses import dataclass, field
from pathlib import Path

from sim.atomic import atomic_write
from sim.parallel import ray_session, run_local_pool
from sim.sweep.plan import RunSpec, SweepPlan


@dataclass
class SweepResult:
    """Where the sweep's records are, and what happened to each run this invocation."""

    out_dir: Path
    finished: list[str] = field(default_factory=list)  # run ids that finished now
    skipped: list[str] = field(default_factory=list)  # already finished before (resume)
    failed: dict[str, str] = field(default_factory=dict)  # run id -> one-line error
    wall_s: float = 0.0

    @property
    def records(self) -> list[dict]:
        return load_records(self.out_dir)


def _atomic_write_json(path: Path, obj: dict) -> None:
    atomic_write(path, json.dumps(obj, indent=1, sort_keys=True).encode())


def load_records(out_dir: Path) -> list[dict]:
    """All finished run records of a sweep directory, sorted by run id."""
    runs = Path(out_dir) / "runs"
    return [json.loads(p.read_text()) for p in sorted(runs.glob("*.json"))]


def execute_run(target: str, spec: RunSpec, out_dir: str) -> dict:
    """Run one spec in this process and persist its record. Returns the record.

    Exceptions from the task are caught and recorded as a failure (status "failed").
    """
    from sim.sweep.tasks import resolve_task

    out = Path(out_dir)
    record = {
        "run_id": spec.run_id,
        "variant_id": spec.variant_id,
        "variant": dict(spec.variant),
        "seed": spec.seed,
        "target": target,
        "pid": os.getpid(),
    }
    t0 = time.perf_counter()
    try:
        task = resolve_task(target)
        metrics = task(spec.params(), spec.seed, out / "artifacts" / spec.run_id)
    except Exception as exc:  # recorded, with traceback, for the user
        record.update(
            status="failed",
            error=f"{type(exc).__name__}: {exc}",
            traceback=traceback.format_exc(),
            wall_s=time.perf_counter() - t0,
        )
        _atomic_write_json(out / "failed" / f"{spec.run_id}.json", record)
        return record
    record.update(status="ok", metrics=metrics, wall_s=time.perf_counter() - t0)
    _atomic_write_json(out / "runs" / f"{spec.run_id}.json", record)
    failed = out / "failed" / f"{spec.run_id}.json"
    if failed.exists():
        failed.unlink()
    return record


def _progress(total: int, enabled: bool):
    from tqdm import tqdm

    quiet = not enabled or os.environ.get("CI") or not sys.stderr.isatty()
    return tqdm(total=total, unit="run", disable=bool(quiet), desc="sweep")


def run_sweep(
    plan: SweepPlan,
    out_dir: str | Path,
    workers: int = 1,
    ray_address: str | None = None,
    use_ray: bool = False,
    max_retries: int = 1,
    progress: bool = True,
    force: bool = False,
) -> SweepResult:
    """Run every spec of ``plan`` not already finished in ``out_dir``.

    Resuming needs the same plan: ``OUT/plan.json`` holds the hash of the target (with
    its scenario file's content), every variant and seed, and the code version; another
    plan in ``out_dir`` raises :class:`PlanMismatchError` before anything runs, and
    ``force=True`` deletes that sweep's files and starts over. Every variant is validated
    (scenario overrides parsed) before any run starts.

    workers     : 1 runs serially in this process; K > 1 uses K local processes (spawn),
                  or K Ray workers with ``use_ray``/``ray_address``.
    ray_address : address of a running Ray cluster ("auto", "ray://host:10001"); implies Ray.
    """
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    from sim.sweep.tasks import resolve_task, target_content, validate_variant

    # fail fast on an unknown target or a bad variant, before anything is written
    resolve_task(plan.target)
    for variant in dict.fromkeys(s.variant for s in plan.specs()):
        validate_variant(plan.target, dict(variant))
    out = Path(out_dir)
    digest = plan.plan_hash(target_content(plan.target))
    check_plan(out, digest, force)
    out.mkdir(parents=True, exist_ok=True)
    _atomic_write_json(out / "plan.json", {**plan.to_dict(), "plan_hash": digest})
    result = SweepResult(out_dir=out)
    todo = []
    for spec in plan.specs():
        if (out / "runs" / f"{spec.run_id}.json").exists():
            result.skipped.append(spec.run_id)
        else:
            todo.append(spec)
    t0 = time.perf_counter()
    bar = _progress(len(todo), progress)

    def collect(record: dict) -> None:
        bar.update(1)
        if record["status"] == "ok":
            result.finished.append(record["run_id"])
        else:
            result.failed[record["run_id"]] = record["error"]

    if use_ray or ray_address:
        _run_ray(plan.target, todo, out, workers, ray_address, collect)
    elif workers == 1:
        for spec in todo:
            collect(execute_run(plan.target, spec, str(out)))
    else:
        _run_local(plan.target, todo, out, workers, max_retries, collect)
    bar.close()
    result.wall_s = time.perf_counter() - t0
    return result


class PlanMismatchError(ValueError):
    """``--out`` holds a sweep of another plan (the message says how to proceed)."""


#: what run_sweep writes into its output directory (and force=True deletes)
SWEEP_ENTRIES = ("plan.json", "runs", "failed", "artifacts")


def check_plan(out: Path, digest: str, force: bool) -> None:
    """Raise PlanMismatchError if ``out`` holds results of a plan with another hash;
    with ``force`` delete that sweep's files instead."""
    import shutil

    plan_file = out / "plan.json"
    has_results = any((out / d).is_dir() and any((out / d).iterdir()) for d in ("runs", "failed"))
    if not plan_file.exists() and not has_results:
        return
    try:
        old = json.loads(plan_file.read_text()) if plan_file.exists() else {}
    except (OSError, ValueError):
        old = {}
    if old.get("plan_hash") == digest:
        return
    if force:
        for name in SWEEP_ENTRIES:
            p = out / name
            if p.is_dir():
                shutil.rmtree(p)
            elif p.exists():
                p.unlink()
        return
    what = (
        f"target {old.get('target')!r}, runs {old.get('runs')}, vary {old.get('vary')}, "
        f"base seed {old.get('base_seed')}"
        if old
        else "results without a readable plan.json"
    )
    raise PlanMismatchError(
        f"--out {str(out)!r} holds another sweep ({what}; plan hash "
        f"{old.get('plan_hash', 'none')} != {digest}: target, variants, seeds or code "
        "version differ); allowed: the same plan to resume, a new --out, or --force to "
        "delete that sweep and start over"
    )


def _failure_record(target: str, spec: RunSpec, error: str) -> dict:
    return {
        "run_id": spec.run_id,
        "variant_id": spec.variant_id,
        "variant": dict(spec.variant),
        "seed": spec.seed,
        "target": target,
        "status": "failed",
        "error": error,
    }


def _run_local(target, todo, out: Path, workers: int, max_retries: int, collect) -> None:
    def finished(spec: RunSpec) -> dict | None:
        path = out / "runs" / f"{spec.run_id}.json"
        return json.loads(path.read_text()) if path.exists() else None

    def give_up(spec: RunSpec, attempts: int) -> None:
        record = _failure_record(target, spec, f"worker process died {attempts} times")
        _atomic_write_json(out / "failed" / f"{spec.run_id}.json", record)
        collect(record)

    run_local_pool(
        execute_run, todo, lambda spec: (target, spec, str(out)), workers, max_retries,
        key=lambda spec: spec.run_id, collect=collect, finished=finished, give_up=give_up,
    )


def _run_ray(target, todo, out: Path, workers: int, address: str | None, collect) -> None:
    with ray_session(workers, address, "sweep") as ray:
        remote = ray.remote(max_retries=2, num_cpus=1)(execute_run)
        refs = [remote.remote(target, spec, str(out)) for spec in todo]
        specs = dict(zip(refs, todo))
        while refs:
            done, refs = ray.wait(refs, num_returns=1)
            for ref in done:
                try:
                    collect(ray.get(ref))
                except Exception as exc:  # worker crash after Ray's retries
                    record = _failure_record(target, specs[ref], f"{type(exc).__name__}: {exc}")
                    _atomic_write_json(out / "failed" / f"{specs[ref].run_id}.json", record)
                    collect(record)

"""Parallel execution shared by sweeps and dataset export: local worker processes that
survive a dying worker, and a Ray session.

Jobs persist their own results (atomically) as they finish, so these helpers only
schedule, collect and retry; what "finished" means is the caller's ``finished(job)``.
"""

from __future__ import annotations

import multiprocessing
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from typing import Any


def run_local_pool(
    fn: Callable[..., Any],
    jobs: Sequence[Any],
    args: Callable[[Any], tuple],
    workers: int,
    max_retries: int,
    *,
    key: Callable[[Any], Any],
    collect: Callable[[Any], None],
    finished: Callable[[Any], Any | None],
    give_up: Callable[[Any, int], None],
    on_retry: Callable[[Any], None] | None = None,
) -> None:
    """Run ``fn(*args(job))`` for every job on ``workers`` spawned processes.

    ``collect(result)`` receives each return value. When a worker process dies (killed,
    out of memory) the pool breaks: jobs whose result is on disk anyway
    (``finished(job)`` returns it) are collected, the others are resubmitted on a fresh
    pool, up to ``max_retries`` times each, then handed to ``give_up(job, attempts)``.
    Spawn, not fork: MuJoCo and OpenMP threads are not fork-safe.
    """
    ctx = multiprocessing.get_context("spawn")
    attempts = {key(j): 0 for j in jobs}
    pending = list(jobs)
    while pending:
        lost = []
        with ProcessPoolExecutor(max_workers=workers, mp_context=ctx) as pool:
            futures = {pool.submit(fn, *args(job)): job for job in pending}
            remaining = set(futures)
            while remaining:
                done, remaining = wait(remaining, return_when=FIRST_COMPLETED)
                for fut in done:
                    job = futures[fut]
                    try:
                        collect(fut.result())
                    except BrokenProcessPool:
                        record = finished(job)
                        if record is not None:
                            collect(record)
                        else:
                            lost.append(job)
        pending = []
        for job in lost:
            attempts[key(job)] += 1
            if attempts[key(job)] > max_retries:
                give_up(job, attempts[key(job)])
            else:
                if on_retry is not None:
                    on_retry(job)
                pending.append(job)


@contextmanager
def ray_session(workers: int, address: str | None, purpose: str) -> Iterator[Any]:
    """Yield the ``ray`` module connected to ``address`` (a running cluster), or to a local
    Ray with ``workers`` CPUs started here and shut down on exit. Raises RuntimeError with
    the install hint when Ray (the ``cluster`` extra) is missing."""
    try:
        import ray
    except ImportError as exc:  # optional extra
        raise RuntimeError(
            f"Ray is not installed: pip install 'undersea[cluster]' to {purpose} on Ray"
        ) from exc
    started_here = not ray.is_initialized()
    if started_here:
        if address:
            ray.init(address=address, log_to_driver=False)
        else:
            ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False)
    try:
        yield ray
    finally:
        if started_here:
            ray.shutdown()

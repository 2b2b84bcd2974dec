"""Fill numba's on-disk cache before the test workers start.

Every numba kernel of ``sim/`` and ``slam/`` is ``cache=True``: the first process that
calls it with given argument types compiles it (seconds per kernel) and writes it beside
its source (``__pycache__/*.nbi, *.nbc``); later processes load it in milliseconds. In a
clean clone the cache is empty, so each pytest-xdist worker, and each subprocess a test
starts (CLI runs, spawned pool workers, Ray workers), compiles whatever kernels it needs
before the other has written them.

:func:`warm` runs the smallest real code paths that reach every kernel, with the types
the code itself passes (a kernel's argument types come from its callers, so no
signature is written down here): short runs of the built-in scenarios (side-scan, FLS,
segmentation, AEKF, navigation suite, MuJoCo step) and a few steps of the
gymnasium envs, batched and single (navigation batch and env kernels). Run as a script,
``python numba_warmup.py GROUP ...`` warms the named groups; ``tests/conftest.py`` runs
the groups in two processes at once from the xdist controller, before the workers start.
"""

from __future__ import annotations

import ast
import hashlib
import importlib.metadata
import os
import pickle
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

#: groups that each warm a disjoint set of kernels, run in parallel processes
GROUPS: dict[str, tuple[str, ...]] = {
    "sidescan": ("sidescan_run",),
    "fls-envs": ("fls_run", "vector_envs", "single_env", "aekf_update"),
}


def sidescan_run() -> None:
    """shipwreck-survey, 4 s with a small side-scan: MuJoCo step, side-scan echo,
    segmentation front end, AEKF, navigation suite."""
    from sim.runner.schedule import ScenarioRun
    from sim.scenario import load_scenario

    scn = load_scenario(
        "shipwreck-survey",
        {"vehicles[0].sonars[0].overrides": {"max_range": 20.0, "samples_per_side": 100}},
    ).with_overrides(duration_s=4.0)
    ScenarioRun(scn).run(4.0)


def fls_run() -> None:
    """harbour-fls, 3 s: the FLS (ray cones, near rays) and its front end."""
    from sim.runner.schedule import ScenarioRun
    from sim.scenario import load_scenario

    scn = load_scenario("harbour-fls").with_overrides(duration_s=3.0)
    ScenarioRun(scn).run(3.0)


def vector_envs() -> None:
    """Both batched envs, 2 vehicles, with navigation sensors: reset and 3 steps."""
    import gymnasium as gym

    import sim.envs  # noqa: F401  (registers the undersea/* ids)

    for env_id in ("undersea/WaypointNav-v0", "undersea/SonarSurvey-v0"):
        for nav in (True, False):
            venv = gym.make_vec(
                env_id, num_envs=2, vectorization_mode="vector_entry_point", nav_sensors=nav
            )
            venv.reset(seed=[0, 1])
            for _ in range(3):
                venv.step(venv.action_space.sample())  # float32, the space's dtype
            venv.step(np.zeros(venv.action_space.shape))  # float64, as the tests pass
            venv.close()


def single_env() -> None:
    """WaypointNav-v0, one vehicle with navigation sensors: reset and 3 steps."""
    import gymnasium as gym

    import sim.envs  # noqa: F401

    env = gym.make("undersea/WaypointNav-v0", nav_sensors=True)
    env.reset(seed=0)
    for _ in range(3):
        env.step(env.action_space.sample())
    env.close()


def aekf_update() -> None:
    """AEKF with state reduction: two scans of one observation (miss counting)."""
    from slam.estimators.aekf import AEKFSlam
    from slam.types import RangeBearing

    f = AEKFSlam(max_misses=3)
    R = np.diag([0.1, 0.01])
    for _ in range(2):
        f.update([RangeBearing(np.array([10.0, 0.2]), R)])


def warm(group: str, verbose: bool = False) -> None:
    """Run every step of ``group`` (a key of :data:`GROUPS`)."""
    for step in GROUPS[group]:
        t0, c0 = time.perf_counter(), time.process_time()
        globals()[step]()
        if verbose:
            print(
                f"{step}: {time.perf_counter() - t0:.1f} s wall, "
                f"{time.process_time() - c0:.1f} s CPU",
                file=sys.stderr,
            )


def _cached(dec: ast.expr) -> bool:
    """``@numba.njit(cache=True)`` / ``@njit(cache=True)``, not ``inline="always"``
    (inlined into its callers, no cache entry of its own)."""
    if not isinstance(dec, ast.Call):
        return False
    name = dec.func.attr if isinstance(dec.func, ast.Attribute) else getattr(dec.func, "id", "")
    kw = {k.arg: getattr(k.value, "value", None) for k in dec.keywords}
    return name == "njit" and kw.get("cache") is True and "inline" not in kw


def kernel_functions(repo: Path) -> list[tuple[Path, str, int]]:
    """(source file, function name, decorator line) of every ``numba.njit(cache=True)``
    function under ``sim/`` and ``slam/`` (read with ``ast``, nothing imported)."""
    found = []
    for top in ("sim", "slam"):
        for path in sorted((repo / top).rglob("*.py")):
            text = path.read_text(encoding="utf-8")
            if "njit(cache=True" not in text:
                continue
            for node in ast.walk(ast.parse(text)):
                if isinstance(node, ast.FunctionDef):
                    found += [
                        (path, node.name, d.lineno) for d in node.decorator_list if _cached(d)
                    ]
    return found


def cold_kernels(repo: Path) -> list[str]:
    """Kernels with no compilation in numba's cache for their current source.

    Reads each kernel's index file (``__pycache__/<file>.<function>-<line>.pyXY.nbi``)
    as numba does: the pickled numba version, then the source stamp (numba ≥ 0.61: the
    SHA-256 of the file; before: its mtime and size) and the compiled signatures; a
    missing or unreadable index, another numba version or a changed source makes the
    kernel cold. With ``NUMBA_CACHE_DIR`` set (cache outside the tree) every kernel
    counts as cold."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return [f"{p.stem}.{name}" for p, name, _ in kernel_functions(repo)]
    numba_version = importlib.metadata.version("numba")
    tag = f"py{sys.version_info.major}{sys.version_info.minor}"
    cold = []
    for path, name, line in kernel_functions(repo):
        index = path.parent / "__pycache__" / f"{path.stem}.{name}-{line}.{tag}.nbi"
        st = path.stat()
        stamps = (hashlib.sha256(path.read_bytes()).digest(), (st.st_mtime, st.st_size))
        try:
            with index.open("rb") as f:
                version = pickle.load(f)
                stamp, overloads = pickle.loads(f.read())
            ok = version == numba_version and stamp in stamps
        except Exception:  # missing, partly written or another format: not cached
            ok = False
        if not (ok and overloads):
            cold.append(f"{path.stem}.{name}")
    return cold


def warm_in_parallel(repo: Path, timeout_s: float = 900.0) -> list[str]:
    """Run each group in its own process (cwd ``repo``); returns the groups that failed
    (their kernels then compile in the tests, as without this)."""
    procs = {
        g: subprocess.Popen(
            [sys.executable, __file__, g],
            cwd=repo,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
        )
        for g in GROUPS
    }
    failed = []
    for g, p in procs.items():
        try:
            _, err = p.communicate(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            p.kill()
            p.communicate()
            err = b"timed out"
        if p.returncode != 0:
            failed.append(f"{g}: {err.decode(errors='replace').strip().splitlines()[-1:]}")
    return failed


if __name__ == "__main__":
    if sys.argv[1:] == ["--cold"]:
        print("\n".join(cold_kernels(Path.cwd())))
    for name in sys.argv[1:] if sys.argv[1:] != ["--cold"] else []:
        warm(name, verbose=True)

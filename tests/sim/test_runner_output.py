"""Run directories never leave partial output behind (issue 15): a runtime error removes
the staging directory, and a stale ``.partial-<pid>`` of a dead process is removed by the
next run to the same ``--out``, while one of a live process is left alone."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from sim.runner.output import RunDirectory, discard_partial_on_error, remove_stale_partials

REPO = Path(__file__).resolve().parents[2]


def _siblings(out: Path) -> list[str]:
    return sorted(p.name for p in out.parent.iterdir() if p.name.startswith(f".{out.name}."))


def test_error_inside_a_decorated_run_leaves_nothing(tmp_path):
    out = tmp_path / "run"

    @discard_partial_on_error
    def failing_run():
        d = RunDirectory(out)
        d.write_json("metrics.json", {"complete": False})
        raise RuntimeError("world build failed")

    with pytest.raises(RuntimeError, match="world build failed"):
        failing_run()
    assert _siblings(out) == [] and not out.exists()


def test_run_scenario_error_before_the_loop_leaves_no_partial(tmp_path, monkeypatch):
    """The probe: an error while the world is built left `.run.partial-PID/` behind."""
    from sim.runner import core
    from sim.scenario import load_scenario

    def broken(*_a, **_k):
        raise ValueError("seabed grid unreadable")

    monkeypatch.setattr(core, "ScenarioRun", broken)
    out = tmp_path / "run"
    with pytest.raises(ValueError, match="seabed grid"):
        core.run_scenario(load_scenario("shipwreck-survey"), out, progress=False)
    assert _siblings(out) == [] and not out.exists()


def test_stale_partial_of_a_sigkilled_run_is_removed_by_the_next_run(tmp_path):
    out = tmp_path / "run"
    script = textwrap.dedent(
        f"""
        import os, signal
        from sim.runner.output import RunDirectory
        d = RunDirectory({str(out)!r})
        d.write_json("metrics.json", {{"complete": False}})
        os.kill(os.getpid(), signal.SIGKILL)
        """
    )
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    r = subprocess.run([sys.executable, "-c", script], env=env, timeout=120)
    assert r.returncode == -9
    (stale,) = _siblings(out)
    assert stale.startswith(".run.partial-")
    # a partial of a live process (this test's parent) must survive
    live = tmp_path / f".run.partial-{os.getppid()}"
    live.mkdir()
    d = RunDirectory(out)
    assert _siblings(out) == sorted([live.name, d.staging.name])
    d.finalize()
    assert _siblings(out) == [live.name]


def test_remove_stale_partials_ignores_other_names(tmp_path):
    out = tmp_path / "run"
    for name in (".run.partial-999999999", ".runx.partial-999999999", ".run.partial-abc"):
        (tmp_path / name).mkdir()
    removed = remove_stale_partials(out)
    assert [p.name for p in removed] == [".run.partial-999999999"]
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        ".run.partial-abc",
        ".runx.partial-999999999",
    ]

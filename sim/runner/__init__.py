"""Headless scenario runs: physics, nav sensors, sonars, front end and SLAM, with outputs
(recording.rrd, metrics.json, figures). See sim/runner/core.py for the loop."""

from sim.runner.output import OutputExistsError, RunDirectory


def __getattr__(name):  # the loop imports mujoco & friends: load it only when asked for
    if name in ("run_scenario", "RunResult", "ScenarioRun"):
        from sim.runner import core

        return getattr(core, name)
    raise AttributeError(name)


__all__ = ["OutputExistsError", "RunDirectory", "RunResult", "ScenarioRun", "run_scenario"]

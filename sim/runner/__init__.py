"""Headless scenario runs: physics, nav sensors, sonars, front end and SLAM, with outputs
(recording.rrd, metrics.json, figures). sim/runner/core.py is the entry point; build.py,
schedule.py (the loop), log.py, score.py and figures.py its parts."""

from sim.runner.output import OutputExistsError, RunDirectory


def __getattr__(name):  # the loop imports mujoco & friends: load it only when asked for
    if name in ("run_scenario", "RunResult"):
        from sim.runner import core

        return getattr(core, name)
    if name == "ScenarioRun":
        from sim.runner import schedule

        return schedule.ScenarioRun
    raise AttributeError(name)


__all__ = ["OutputExistsError", "RunDirectory", "RunResult", "ScenarioRun", "run_scenario"]

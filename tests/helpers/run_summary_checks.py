"""Checks shared by the scenario-run tests: a run's metrics and printed summary."""

from __future__ import annotations

#: words every vehicle's summary line carries (SLAM against dead reckoning)
SUMMARY_WORDS = ("ATE SLAM", "dead reckoning", "pose NEES", "inside 95 %", "RMSE", "duplicated")


def assert_prints_and_writes_slam_and_dead_reckoning(res) -> None:
    """Every vehicle of ``res`` (a :class:`sim.runner.RunResult`) has the SLAM and dead
    reckoning figures in its metrics (pose ATE, dead-reckoning ATE, pose NEES mean and
    fraction inside its 95 % interval; landmark counts) and on its summary line."""
    text = res.summary()
    for v_name, v in res.metrics["vehicles"].items():
        po, lm = v["pose"], v["landmarks"]
        for key in ("ate_m", "dead_reckoning_ate_m", "nees_mean", "nees_in_95_interval"):
            assert po[key] is not None, (v_name, key)
        for key in ("n_estimated", "n_duplicated_objects"):
            assert key in lm, (v_name, key)
        line = next(ln for ln in text.splitlines() if ln.strip().startswith(f"{v_name}:"))
        for word in SUMMARY_WORDS:
            assert word in line, (word, line)

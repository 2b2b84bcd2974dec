"""Monte Carlo sweeps: run many seeded variants of a scenario or SLAM experiment in
parallel (serial, local processes, or a Ray cluster), persist each finished run at once,
resume from finished runs, and aggregate metrics with confidence intervals.
"""

from sim.sweep.aggregate import SweepTable, aggregate_runs, nees_consistency
from sim.sweep.plan import RunSpec, SweepPlan, parse_vary
from sim.sweep.runner import PlanMismatchError, SweepResult, run_sweep

__all__ = [
    "PlanMismatchError",
    "RunSpec",
    "SweepPlan",
    "SweepResult",
    "SweepTable",
    "aggregate_runs",
    "nees_consistency",
    "parse_vary",
    "run_sweep",
]

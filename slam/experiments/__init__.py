"""The reference's simulated SLAM experiments (dense loop, line, segmentation loop), Monte
Carlo runs, metrics and figures. CLI: ``undersea slam-experiment``."""

from slam.experiments.runner import (
    EXPERIMENTS,
    ExperimentSpec,
    MonteCarloResult,
    RunResult,
    get_experiment,
    run_monte_carlo,
    run_once,
    save_results,
    with_loops,
)

__all__ = [
    "EXPERIMENTS",
    "ExperimentSpec",
    "MonteCarloResult",
    "RunResult",
    "get_experiment",
    "run_monte_carlo",
    "run_once",
    "save_results",
    "with_loops",
]

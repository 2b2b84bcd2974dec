"""SLAM estimators behind one interface (see base.py): AEKF-SLAM, FastSLAM 2.0, iSAM2.

``make_estimator(name, **params)`` builds one by name. FastSLAM 2.0 and iSAM2 are imported
only when asked for; iSAM2 needs the optional extra ``undersea[baselines]`` (gtsam).
"""

from __future__ import annotations

import importlib

from slam.estimators.base import SlamEstimator, UpdateResult

__all__ = ["ESTIMATORS", "SlamEstimator", "UpdateResult", "make_estimator"]

#: estimator name -> module under slam.estimators
ESTIMATORS: dict[str, str] = {
    "aekf": "aekf",
    "fastslam2": "fastslam2",
    "isam2": "isam2",
    "aekf-submap": "aekf_submap",  # beyond the contract: sub-mapping AEKF for large maps
    "aekf-robocentric": "aekf_robocentric",  # beyond the contract: robocentric AEKF
}


def _estimator_class(name: str, module):
    """The class in ``module`` whose ``name`` attribute is ``name`` (the protocol's name)."""
    for attr in vars(module).values():
        if (
            isinstance(attr, type)
            and getattr(attr, "name", None) == name
            and callable(getattr(attr, "predict", None))
            and callable(getattr(attr, "update", None))
        ):
            return attr
    raise ImportError(
        f"slam.estimators.{ESTIMATORS[name]} defines no estimator class named {name!r}"
    )


def make_estimator(name: str, **params) -> SlamEstimator:
    """Build the estimator ``name`` ("aekf", "fastslam2", "isam2"; also "aekf-submap")
    with its parameters.

    Raises ``ValueError`` for an unknown name and ``ImportError`` with the install hint
    when iSAM2's optional dependency gtsam is missing.
    """
    if name not in ESTIMATORS:
        raise ValueError(f"unknown estimator {name!r}; allowed: {', '.join(ESTIMATORS)}")
    try:
        module = importlib.import_module(f"slam.estimators.{ESTIMATORS[name]}")
    except ModuleNotFoundError as exc:
        if exc.name == "gtsam":
            raise ImportError(
                f"estimator {name!r} needs gtsam: pip install 'undersea[baselines]'"
            ) from exc
        raise
    return _estimator_class(name, module)(**params)

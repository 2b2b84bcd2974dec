"""Average pose NEES of several AEKF variants on the same Monte Carlo runs, one figure.

The reference's AEKF (Bailey's gates and Jacobians) against the ``consistent`` preset and
any ``KEY=VALUE`` variant, on the thesis's dense loop by default; prints each variant's
time-mean average NEES, the fraction of scans inside the 95 % χ² bounds and the median
landmark RMSE, and writes the figure (docs/figures/dense_loop_nees_variants.png comes
from the defaults).

    .venv/bin/python scripts/nees_comparison.py [--experiment dense-loop] [--dt 0.0125]
        [--runs 50] [--out docs/figures/dense_loop_nees_variants.png]
        [--variant "label:key=value,key=value" ...]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from slam.experiments import get_experiment, run_monte_carlo  # noqa: E402
from slam.experiments.figures import plot_nees_curves  # noqa: E402

DEFAULT_VARIANTS = (
    "reference AEKF (Bailey's gates, standard Jacobians):preset=reference",
    "preset=consistent (FEJ + JCBB + iterated loop closures):preset=consistent",
)


def _variant(text: str) -> tuple[str, dict]:
    label, _, params = text.rpartition(":")
    if not label:
        raise argparse.ArgumentTypeError(f"--variant expects LABEL:key=value,..., got {text!r}")
    out: dict = {}
    for item in filter(None, params.split(",")):
        key, sep, val = item.partition("=")
        if not sep:
            raise argparse.ArgumentTypeError(f"variant parameter must be key=value, got {item!r}")
        try:
            out[key] = json.loads(val)
        except json.JSONDecodeError:
            out[key] = val
    return label, out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--experiment", default="dense-loop")
    ap.add_argument("--dt", type=float, default=0.0125)
    ap.add_argument("--runs", type=int, default=50)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument(
        "--out", default=str(REPO / "docs" / "figures" / "dense_loop_nees_variants.png")
    )
    ap.add_argument("--variant", type=_variant, action="append", default=None)
    args = ap.parse_args(argv)
    if args.runs < 2:
        ap.error(f"--runs must be >= 2 for an average NEES, got {args.runs}")
    variants = args.variant or [_variant(v) for v in DEFAULT_VARIANTS]
    spec = get_experiment(args.experiment, dt=args.dt)
    curves, bounds = {}, None
    for label, params in variants:
        mc = run_monte_carlo(spec, "aekf", runs=args.runs, seed=args.seed, estimator_params=params)
        bounds = mc.nees_bounds
        avg = mc.avg_nees
        inside = float(np.mean((avg >= bounds[0]) & (avg <= bounds[1])))
        rmse = float(np.median([r.landmark_rmse for r in mc.runs]))
        print(
            f"{label}: time-mean average NEES {np.nanmean(avg):.2f}, {100 * inside:.0f} % of "
            f"scans inside [{bounds[0]:.2f}, {bounds[1]:.2f}], median landmark RMSE {rmse:.2f} m"
        )
        curves[f"{label}: {np.nanmean(avg):.2f}, {100 * inside:.0f} % inside"] = avg
    t = (np.arange(next(iter(curves.values())).size) + 1) * spec.sim.dt_observe
    path = plot_nees_curves(
        curves,
        bounds,
        args.out,
        t=t,
        title=f"{args.experiment}, dt {args.dt} s, average pose NEES over {args.runs} runs",
    )
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

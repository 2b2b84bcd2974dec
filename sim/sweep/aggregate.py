"""Aggregate sweep records into a per-variant table with confidence intervals, and the
Monte Carlo NEES consistency test over runs."""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import stats


def flatten_metrics(metrics: dict, prefix: str = "") -> dict[str, float]:
    """Nested dict -> {"a.b": float} keeping finite-or-nan numeric scalars only."""
    flat: dict[str, float] = {}
    for key, value in metrics.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            flat.update(flatten_metrics(value, name + "."))
        elif isinstance(value, bool):
            flat[name] = float(value)
        elif isinstance(value, int | float) and not isinstance(value, bool):
            flat[name] = float(value)
    return flat


@dataclass(frozen=True)
class SweepTable:
    """Rows: one per (variant, metric): n, mean, std, and the 95 % t-interval of the mean."""

    rows: list[dict]

    def to_csv(self, path: str | Path) -> Path:
        path = Path(path)
        with path.open("w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=["variant", "metric", "n", "mean", "std", "ci95_low", "ci95_high"])
            w.writeheader()
            w.writerows(self.rows)
        return path

    def to_parquet(self, path: str | Path) -> Path | None:
        """Write Parquet when pyarrow is installed; returns None otherwise."""
        try:
            import pyarrow as pa
            import pyarrow.parquet as pq
        except ImportError:
            return None
        cols = {k: [r[k] for r in self.rows] for k in ("variant", "metric", "n", "mean", "std", "ci95_low", "ci95_high")}
        pq.write_table(pa.table(cols), str(path))
        return Path(path)

    def get(self, variant: str, metric: str) -> dict:
        for r in self.rows:
            if r["variant"] == variant and r["metric"] == metric:
                return r
        raise KeyError(f"no row for variant {variant!r}, metric {metric!r}")


def aggregate_runs(records: list[dict], confidence: float = 0.95) -> SweepTable:
    """Mean, sample std and the Student-t confidence interval of the mean, per variant and
    metric, over the finished runs. A metric that is nan in some runs is aggregated over
    its finite values (n counts them)."""
    by_variant: dict[str, list[dict[str, float]]] = {}
    for rec in records:
        if rec.get("status") != "ok":
            continue
        by_variant.setdefault(rec["variant_id"], []).append(flatten_metrics(rec["metrics"]))
    rows = []
    for variant in sorted(by_variant):
        runs = by_variant[variant]
        names = sorted({k for r in runs for k in r})
        for name in names:
            vals = np.array([r[name] for r in runs if name in r], dtype=float)
            vals = vals[np.isfinite(vals)]
            n = len(vals)
            mean = float(vals.mean()) if n else math.nan
            std = float(vals.std(ddof=1)) if n > 1 else math.nan
            if n > 1:
                half = stats.t.ppf(0.5 + confidence / 2, n - 1) * std / math.sqrt(n)
                lo, hi = mean - half, mean + half
            else:
                lo = hi = math.nan
            rows.append(
                {"variant": variant, "metric": name, "n": n, "mean": mean, "std": std,
                 "ci95_low": lo, "ci95_high": hi}
            )
    return SweepTable(rows=rows)


def nees_consistency(
    records: list[dict], key: str = "nees_series", dof: int = 3, confidence: float = 0.95
) -> dict[str, dict]:
    """Monte Carlo NEES test per variant (Bar-Shalom): average the per-step NEES series
    over the N runs; a consistent filter keeps it inside
    ``[chi2.ppf(a/2, N·dof)/N, chi2.ppf(1 − a/2, N·dof)/N]``. Runs are truncated to the
    shortest series. Returns per variant: n_runs, bounds, mean of the averaged NEES and the
    fraction of steps inside the bounds."""
    by_variant: dict[str, list[np.ndarray]] = {}
    for rec in records:
        if rec.get("status") != "ok" or key not in rec.get("metrics", {}):
            continue
        by_variant.setdefault(rec["variant_id"], []).append(np.asarray(rec["metrics"][key], float))
    out = {}
    for variant, series in sorted(by_variant.items()):
        n = len(series)
        length = min(len(s) for s in series)
        if length == 0:
            continue
        avg = np.mean([s[:length] for s in series], axis=0)
        alpha = 1.0 - confidence
        lo = stats.chi2.ppf(alpha / 2, n * dof) / n
        hi = stats.chi2.ppf(1 - alpha / 2, n * dof) / n
        out[variant] = {
            "n_runs": n,
            "dof": dof,
            "bounds": [float(lo), float(hi)],
            "mean_nees": float(np.nanmean(avg)),
            "fraction_inside": float(np.mean((avg >= lo) & (avg <= hi))),
        }
    return out

"""Side-by-side comparison of two waterfalls' realism statistics (SIM against REAL).

Rows are the statistics of :mod:`slam.realism.statistics` per side, each with the
tolerance issue 11 sets for a calibrated simulator (CV ±10 %, dB std ±0.5 dB, lag-1 ±0.1,
water column ±6 dB, dynamic range ±8 dB, saturation within a factor 2 (or both below
0.1 %), texture-histogram
JS distance < 0.1), then the histogram distances per side.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from slam.realism.statistics import WaterfallStatistics
from slam.realism.textures import histogram_distances, intensity_centres, lbp_centres

#: statistic -> (label, kind, tolerance); kind: "rel" relative, "abs" absolute, "factor".
TOLERANCES: dict[str, tuple[str, str, float]] = {
    "cv_amplitude": ("speckle CV of amplitude, 16-px patches", "rel", 0.10),
    "db_std": ("std of dB, 16-px patches (dB)", "abs", 0.5),
    "lag1_range": ("lag-1 correlation along range", "abs", 0.1),
    "lag1_ping": ("lag-1 correlation across pings", "abs", 0.1),
    "water_column_db": ("water column re seabed-profile peak (dB)", "abs", 6.0),
    "dynamic_range_db": ("whole-side dynamic range P99/P1 (dB)", "abs", 8.0),
    "saturation": ("saturation fraction", "factor", 2.0),
}
#: statistics reported beside the table without a tolerance of issue 11 (statistic ->
#: label): not part of "all within" nor of the calibration's convergence.
REPORTED: dict[str, str] = {
    "texture_tile_db": "seabed texture, 16-px tile means (dB)",
    "far_range_db": "far-range seabed (outer quarter) re profile peak (dB)",
}
#: saturation fractions both below this match whatever their ratio (a handful of clipped
#: samples is noise, not a level).
SATURATION_FLOOR = 1e-3
#: largest texture (LBP) histogram Jensen–Shannon distance for a match.
TEXTURE_JS_MAX = 0.1


def within(key: str, sim: float, real: float) -> bool | None:
    """Whether ``sim`` is within the tolerance of ``real`` for statistic ``key``; None when
    either is not finite."""
    if not (math.isfinite(sim) and math.isfinite(real)):
        return None
    _, kind, tol = TOLERANCES[key]
    if kind == "rel":
        return abs(sim - real) <= tol * abs(real)
    if kind == "abs":
        return abs(sim - real) <= tol
    if max(sim, real) < SATURATION_FLOOR:
        return True
    if real == 0.0 or sim == 0.0:
        return False
    return 1.0 / tol <= sim / real <= tol


@dataclass(frozen=True)
class Row:
    key: str
    label: str
    side: str
    sim: float
    real: float
    ok: bool | None


@dataclass(frozen=True)
class Comparison:
    rows: tuple[Row, ...]
    #: side -> {"intensity": {kl, js, emd}, "lbp": {kl, js, emd}}
    distances: dict[str, dict[str, dict[str, float]]]
    #: REPORTED statistics (ok None: no tolerance)
    reported: tuple[Row, ...] = ()

    def all_within(self) -> bool:
        """Every statistic within tolerance and every texture JS below TEXTURE_JS_MAX."""
        stats_ok = all(r.ok is True for r in self.rows)
        tex_ok = all(d["lbp"]["js"] < TEXTURE_JS_MAX for d in self.distances.values())
        return stats_ok and tex_ok

    def to_dict(self) -> dict:
        """JSON-ready (NaN and inf become None)."""
        return json_ready(
            {
                "statistics": [
                    {
                        "key": r.key,
                        "label": r.label,
                        "side": r.side,
                        "sim": r.sim,
                        "real": r.real,
                        "within_tolerance": r.ok,
                    }
                    for r in self.rows
                ],
                "reported": [
                    {"key": r.key, "label": r.label, "side": r.side, "sim": r.sim, "real": r.real}
                    for r in self.reported
                ],
                "distances": self.distances,
                "texture_js_max": TEXTURE_JS_MAX,
                "all_within": self.all_within(),
            }
        )


def json_ready(x):
    """Nested dicts/lists with NaN and inf floats replaced by None (for strict JSON)."""
    if isinstance(x, float):
        return x if math.isfinite(x) else None
    if isinstance(x, dict):
        return {k: json_ready(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [json_ready(v) for v in x]
    return x


def compare(sim: WaterfallStatistics, real: WaterfallStatistics) -> Comparison:
    """Rows of SIM against REAL per side, and the histogram distances (p = REAL)."""
    rows, info = [], []
    dists: dict[str, dict[str, dict[str, float]]] = {}
    for side, s in sim.sides().items():
        r = real.sides()[side]
        for key, (label, _, _) in TOLERANCES.items():
            a, b = float(getattr(s, key)), float(getattr(r, key))
            rows.append(Row(key, label, side, a, b, within(key, a, b)))
        for key, label in REPORTED.items():
            info.append(Row(key, label, side, float(getattr(s, key)), float(getattr(r, key)), None))
        di = histogram_distances(r.hist_intensity, s.hist_intensity, intensity_centres())
        dl = histogram_distances(r.hist_lbp, s.hist_lbp, lbp_centres())
        dists[side] = {"intensity": vars(di), "lbp": vars(dl)}
    return Comparison(tuple(rows), dists, tuple(info))


def _fmt(key: str, v: float) -> str:
    if not math.isfinite(v):
        return "n/a"
    if key == "saturation":
        return f"{100 * v:.2f} %"
    if key.endswith("_db") or key == "db_std":
        return f"{v:.1f}"
    return f"{v:.3f}"


def format_table(c: Comparison, names: tuple[str, str] = ("SIM", "REAL")) -> str:
    """Plain-text table: one line per statistic, port and starboard side by side."""
    head = (
        f"{'statistic':44s} {names[0] + ' port':>12s} {names[1] + ' port':>12s} "
        f"{names[0] + ' stbd':>12s} {names[1] + ' stbd':>12s}  ok"
    )
    lines = [head, "-" * len(head)]
    by = {(r.key, r.side): r for r in c.rows}
    for key, (label, _, _) in TOLERANCES.items():
        p, s = by[(key, "port")], by[(key, "starboard")]
        mark = "".join({True: "y", False: "n", None: "?"}[r.ok] for r in (p, s))
        lines.append(
            f"{label:44s} {_fmt(key, p.sim):>12s} {_fmt(key, p.real):>12s} "
            f"{_fmt(key, s.sim):>12s} {_fmt(key, s.real):>12s}  {mark}"
        )
    info = {(r.key, r.side): r for r in c.reported}
    for key, label in REPORTED.items():
        if (key, "port") in info:
            p, s = info[(key, "port")], info[(key, "starboard")]
            lines.append(
                f"{label:44s} {_fmt(key, p.sim):>12s} {_fmt(key, p.real):>12s} "
                f"{_fmt(key, s.sim):>12s} {_fmt(key, s.real):>12s}  -"
            )
    lines.append("")
    lines.append(f"{'histogram distance (REAL‖SIM)':44s} {'port':>12s} {'':>12s} {'stbd':>12s}")
    for hist in ("intensity", "lbp"):
        for m, unit in (
            ("kl", "nats"),
            ("js", ""),
            ("emd", "dB" if hist == "intensity" else "code"),
        ):
            label = f"{hist} {m.upper()} {unit}".strip()
            pv, sv = c.distances["port"][hist][m], c.distances["starboard"][hist][m]
            lines.append(f"{label:44s} {pv:12.4f} {'':>12s} {sv:12.4f}")
    lines.append("")
    verdict = "yes" if c.all_within() else "no"
    lines.append(f"all within issue-11 tolerances (texture JS < {TEXTURE_JS_MAX}): {verdict}")
    return "\n".join(lines)

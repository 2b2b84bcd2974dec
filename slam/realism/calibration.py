"""Fit a sonar model's free parameters so that its waterfall matches a recording's
realism statistics.

The model is a callable ``simulate(values: dict[str, float]) -> (P, 2S) intensity`` (a
ray-cast survey, or the statistical model of :mod:`slam.realism.synthetic`); the fit
knows nothing else about it. The parameters are a small vector of named, bounded scalars
(:class:`Parameter`), fitted by bounded nonlinear least squares on the residual vector
(``scipy.optimize.least_squares``, trust-region reflective, finite-difference Jacobian
with steps of ``diff_step`` of each range) in coordinates scaled to [0, 1] (log-scaled
when ``log``). The simulator should be seeded the same way at every call (common random
numbers), so the objective is deterministic.

Objective: the mean over the features below, on each side, of the squared residual *in
units of the issue-11 tolerance* (1 = at the edge of the tolerance): speckle CV (relative), dB std, lag-1 range, lag-1 pings, water-column level,
dynamic range, log10(saturation + SATURATION_FLOOR) (factor 2 ↔ log10 2; the floor keeps
the residual smooth where a model barely clips), the texture (LBP) JS
distance to the recording's histogram over 0.1, the seabed texture at the patch scale
(``texture_tile_db``, 1-dB units; not an issue-11 row), optionally the far-range seabed
level (``far_range_db``, 2-dB units), and — only to guide the gain where a model
does not clip yet — the headroom (clip level re P99, dB) in 1-dB units. A model call that fails (``ValueError``: no seabed
in the simulated image, …) costs ``FAILED_LOSS``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares, minimize
from scipy.spatial.distance import jensenshannon

from slam.realism.compare import SATURATION_FLOOR, TEXTURE_JS_MAX, TOLERANCES
from slam.realism.statistics import RealismConfig, WaterfallStatistics, waterfall_statistics

FAILED_LOSS = 1e4
FEATURES = (
    "cv_amplitude",
    "db_std",
    "lag1_range",
    "lag1_ping",
    "water_column_db",
    "dynamic_range_db",
    "saturation",
    "texture_js",
    "headroom_db",
)
#: features that must be within tolerance for convergence (the issue-11 table); the
#: headroom (clip re P99, 1-dB units) only guides the gain where nothing clips yet.
CONVERGENCE_FEATURES = FEATURES[:-1]
HEADROOM_TOLERANCE_DB = 1.0
#: tolerance of the seabed texture at the patch scale (statistics.tile_texture_db), dB:
#: not an issue-11 row; fitted so the texture that gives the in-patch speckle statistics
#: is not painted stronger across patches than the recording's (sediment blobs)
TEXTURE_TILE_TOLERANCE_DB = 1.0
SIDES = ("port", "starboard")
#: residual keys: every convergence feature on both sides, then the guides.
RESIDUAL_KEYS = tuple(f"{k}.{s}" for k in CONVERGENCE_FEATURES for s in SIDES) + tuple(
    f"headroom_db.{s}" for s in SIDES
)
#: the optional convergence feature of ``calibrate(..., fit_tile_texture=True)``
TILE_FEATURE = "texture_tile_db"
#: tolerance of the far-range seabed level (statistics.far_range_level), dB: not an
#: issue-11 row; fitted with the low-grazing law so the level's fall with altitude is
#: the recording's
FAR_RANGE_TOLERANCE_DB = 2.0
#: the optional convergence feature of ``calibrate(..., fit_far_range=True)``
FAR_FEATURE = "far_range_db"


def residual_keys(
    fit_tile_texture: bool = False,
    fit_far_range: bool = False,
    sides: Sequence[str] = SIDES,
) -> tuple[tuple[str, ...], int]:
    """(residual keys, how many of them are convergence features), the seabed texture at
    the patch scale among them when ``fit_tile_texture``, the far-range level when
    ``fit_far_range``; only the ``sides`` given (a per-side fit scores one side)."""
    sides = tuple(sides)
    if not sides or any(s not in SIDES for s in sides) or len(set(sides)) != len(sides):
        raise ValueError(f"sides = {sides!r}; allowed: a non-empty subset of {SIDES}")
    extra = (TILE_FEATURE,) * fit_tile_texture + (FAR_FEATURE,) * fit_far_range
    conv = (*CONVERGENCE_FEATURES, *extra)
    order = tuple(s for s in SIDES if s in sides)
    keys = tuple(f"{k}.{s}" for k in conv for s in order)
    return keys + tuple(f"headroom_db.{s}" for s in order), len(order) * len(conv)


class _Budget(Exception):
    """Raised inside the objective to end the search: the model-run budget is spent, or a
    point is well inside every tolerance (``good_enough``)."""


class CalibrationError(ValueError):
    """The fit did not converge (the message says which statistics are off and why);
    ``best`` holds the best result found (None when the model gave no image)."""

    def __init__(self, message: str, best: CalibrationResult | None = None):
        super().__init__(message)
        self.best = best


@dataclass(frozen=True)
class Parameter:
    """A free parameter: name (the model's key), bounds and start value, log-scaled search
    when ``log`` (then lo > 0)."""

    name: str
    lo: float
    hi: float
    initial: float
    log: bool = False

    def __post_init__(self) -> None:
        if not (self.lo < self.hi and self.lo <= self.initial <= self.hi):
            raise ValueError(
                f"parameter {self.name}: need lo < hi and lo <= initial <= hi, got "
                f"{self.lo}, {self.hi}, {self.initial}"
            )
        if self.log and self.lo <= 0:
            raise ValueError(f"parameter {self.name}: log scale needs lo > 0, got {self.lo}")

    def to_unit(self, v: float) -> float:
        if self.log:
            return math.log(v / self.lo) / math.log(self.hi / self.lo)
        return (v - self.lo) / (self.hi - self.lo)

    def from_unit(self, u: float) -> float:
        u = min(max(u, 0.0), 1.0)
        if self.log:
            return self.lo * (self.hi / self.lo) ** u
        return self.lo + u * (self.hi - self.lo)


def _one(key: str, s: float, r: float) -> float:
    _, kind, tol = TOLERANCES[key]
    if kind == "rel":
        return (s - r) / (tol * abs(r))
    if kind == "abs":
        return (s - r) / tol
    ls, lr = (math.log10(x + SATURATION_FLOOR) for x in (s, r))
    return (ls - lr) / math.log10(tol)


def residuals(sim: WaterfallStatistics, real: WaterfallStatistics) -> dict[str, float]:
    """Residual per feature and side (key ``"<feature>.<side>"``) in tolerance units,
    signed; nan when a statistic is missing."""
    out = {}
    for side in SIDES:
        a, b = sim.sides()[side], real.sides()[side]
        for key in TOLERANCES:
            out[f"{key}.{side}"] = _one(key, float(getattr(a, key)), float(getattr(b, key)))
        js = jensenshannon(b.hist_lbp, a.hist_lbp, base=2)
        out[f"texture_js.{side}"] = float(js) / TEXTURE_JS_MAX
        out[f"texture_tile_db.{side}"] = (
            a.texture_tile_db - b.texture_tile_db
        ) / TEXTURE_TILE_TOLERANCE_DB
        out[f"far_range_db.{side}"] = (a.far_range_db - b.far_range_db) / FAR_RANGE_TOLERANCE_DB
        out[f"headroom_db.{side}"] = (a.headroom_db - b.headroom_db) / HEADROOM_TOLERANCE_DB
    return out


def residual_vector(res: dict[str, float], keys: tuple[str, ...] = RESIDUAL_KEYS) -> np.ndarray:
    """Residuals, convergence features first (``keys`` order); a missing statistic
    (nan) counts as 10 tolerances."""
    v = np.array([res[k] for k in keys], dtype=np.float64)
    return np.where(np.isfinite(v), v, 10.0)


def loss(res: dict[str, float]) -> float:
    """Mean squared residual (``residual_vector``)."""
    return float(np.mean(residual_vector(res) ** 2))


def _worst(rv: np.ndarray, n_conv: int = 2 * len(CONVERGENCE_FEATURES)) -> float:
    """Largest |residual| over the convergence features (the first ``n_conv``)."""
    return float(np.abs(rv[:n_conv]).max())


def _simplex(u: np.ndarray, step: float = 0.15) -> np.ndarray:
    """Initial Nelder–Mead simplex around ``u`` (steps towards the middle of [0, 1])."""
    pts = [u]
    for i in range(len(u)):
        d = np.zeros_like(u)
        d[i] = step if u[i] < 0.5 else -step
        pts.append(u + d)
    return np.clip(np.array(pts), 0.0, 1.0)


@dataclass(frozen=True)
class CalibrationResult:
    """Fitted values, losses (initial and final), residuals after the fit, the number of
    model calls, and the statistics of the model before (initial values) and after."""

    values: dict[str, float]
    initial_values: dict[str, float]
    loss: float
    initial_loss: float
    residuals: dict[str, float]
    evaluations: int
    before: WaterfallStatistics
    after: WaterfallStatistics


def calibrate(
    simulate: Callable[[dict[str, float]], np.ndarray],
    target: WaterfallStatistics,
    parameters: Sequence[Parameter],
    *,
    max_evaluations: int = 200,
    max_residual: float = 1.0,
    good_enough: float | None = None,
    diff_step: float = 0.03,
    model_config: RealismConfig | None = None,
    fit_tile_texture: bool = False,
    fit_far_range: bool = False,
    model_first_return: float | np.ndarray | None = None,
    sides: Sequence[str] = SIDES,
) -> CalibrationResult:
    """Fit ``parameters`` of ``simulate`` to the ``target`` statistics.

    ``model_config`` is how the model's images are measured: give it the model's
    ``full_scale`` (its clip level), so that the saturation and headroom follow the gain
    even where the model does not clip. ``fit_tile_texture``: the seabed texture at the
    patch scale (``texture_tile_db``, within 1 dB) is a convergence feature too — for a
    model whose texture level and size are free (the ray-cast survey), so the texture
    that gives the in-patch statistics is not painted stronger across patches than the
    recording's. ``fit_far_range``: the far-range seabed level (``far_range_db``, within
    2 dB) is a convergence feature too — for a model whose low-grazing law is free.
    ``model_first_return``: the model images' first bottom return (sample index, every
    ping, or one per ping) instead of the detector — for a model whose water column is not
    darker than its seabed (recreational displays), flown at a known altitude.
    ``sides``: the sides scored (default both); ``("port",)`` fits the parameters to the
    port side alone (a side-scan has one transducer and receive channel per side, so
    per-side gain and texture are physical: fit each side on its own).

    Converged means every feature within ``max_residual`` tolerances (issue 11: every row
    of the table within its tolerance). ``max_evaluations`` bounds the model runs in all
    (finite differences included); the search stops early at the first point with every
    feature within ``good_enough`` tolerances (None: search to the end); the result is the
    best point seen (least loss). Raises CalibrationError when the model fails at
    the start values or the fit does not converge (naming the statistics that are off).
    """
    model_config = model_config or RealismConfig()
    if not parameters:
        raise ValueError("calibrate needs at least one parameter")
    names = [p.name for p in parameters]
    if len(set(names)) != len(names):
        raise ValueError(f"parameter names must be unique, got {names}")
    cache: dict[tuple, tuple[np.ndarray, WaterfallStatistics | None, dict]] = {}
    keys, n_conv = residual_keys(fit_tile_texture, fit_far_range, sides)
    failed = np.full(len(keys), math.sqrt(FAILED_LOSS))

    def values_of(u: np.ndarray) -> dict[str, float]:
        return {p.name: p.from_unit(float(x)) for p, x in zip(parameters, u, strict=True)}

    def evaluate(u: np.ndarray):
        key = tuple(np.round(np.clip(u, 0, 1), 12))
        if key not in cache:
            if len(cache) >= max_evaluations:
                raise _Budget
            try:
                img = simulate(values_of(np.asarray(key)))
                fr = None
                if model_first_return is not None:
                    fr = np.broadcast_to(
                        np.asarray(model_first_return, float), np.shape(img)[:1]
                    ).copy()
                st = waterfall_statistics(img, model_config, first_return=fr)
            except ValueError:
                cache[key] = (failed, None, {})
            else:
                res = residuals(st, target)
                cache[key] = (residual_vector(res, keys), st, res)
            if good_enough is not None and cache[key][1] is not None:
                if _worst(cache[key][0], n_conv) <= good_enough:
                    raise _Budget
        return cache[key]

    def best_seen() -> np.ndarray:
        k = min(cache, key=lambda k: float(np.mean(cache[k][0] ** 2)))
        return np.asarray(k, dtype=np.float64)

    u0 = np.array([p.to_unit(p.initial) for p in parameters])
    try:
        evaluate(u0)
    except _Budget:  # the start is good enough already (or a budget of one run)
        pass
    r0, st0, _ = evaluate(u0)  # from the cache
    if st0 is None:
        raise CalibrationError(
            f"the model gives no usable image at the start values {values_of(u0)} "
            "(no seabed or too short): check the preset, altitude and range"
        )
    done = good_enough is not None and _worst(r0, n_conv) <= good_enough
    try:
        if done:
            raise _Budget
        opt = least_squares(
            lambda u: evaluate(u)[0],
            u0,
            bounds=(0.0, 1.0),
            diff_step=diff_step,
            max_nfev=max_evaluations,
            xtol=1e-3,
            ftol=1e-4,
        )
        u = min((opt.x, best_seen()), key=lambda x: float(np.mean(evaluate(x)[0] ** 2)))
    except _Budget:
        u = best_seen()
    left = max_evaluations - len(cache)
    if not done and _worst(evaluate(u)[0], n_conv) > max_residual and left > len(u) + 1:
        # least squares stalls where a feature is flat (no clipping at all): polish by
        # Nelder–Mead from the better of the start and the least-squares point
        start = min((u0, u), key=lambda x: float(np.mean(evaluate(x)[0] ** 2)))
        try:
            minimize(
                lambda x: float(np.mean(evaluate(x)[0] ** 2)),
                start,
                method="Nelder-Mead",
                bounds=[(0.0, 1.0)] * len(u),
                options={
                    "maxfev": left,
                    "xatol": 2e-3,
                    "fatol": 1e-3,
                    "initial_simplex": _simplex(start),
                },
            )
        except _Budget:
            pass
        u = best_seen()
    rv, st, res = evaluate(u)
    result = None
    if st is not None:
        result = CalibrationResult(
            values=values_of(u),
            initial_values=values_of(u0),
            loss=float(np.mean(rv**2)),
            initial_loss=float(np.mean(r0**2)),
            residuals=res,
            evaluations=len(cache),
            before=st0,
            after=st,
        )
    if result is None or not _worst(rv, n_conv) <= max_residual:
        conv = {k: v for k, v in res.items() if k in keys[:n_conv]}
        off = sorted(conv.items(), key=lambda kv: -abs(kv[1]))[:3]
        worst = ", ".join(f"{k} {v:+.1f} tolerances" for k, v in off)
        raise CalibrationError(
            f"calibration did not converge: a statistic is {_worst(rv, n_conv):.2g} tolerances "
            f"off (allowed {max_residual:g}; loss {float(np.mean(rv**2)):.3g}) after "
            f"{len(cache)} model runs; furthest off: {worst or 'no image'}",
            result,
        )
    return result

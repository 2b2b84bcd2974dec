"""Side-scan intensity normalization: MIRA (thesis Ch. 4.1.2) and the Dark Channel Prior
baseline (Ch. 4.1.3).

MIRA — MIxed exponential Regression Analysis. Per side (port, starboard) fit

    f(z) = a·exp(b·z) + c·exp(d·z),   z = sample index counted from the nadir outward,

to the samples of one chosen ping k (eq. 4.4) with ``scipy.optimize.least_squares``
(bounded, robust soft-L1 loss, several deterministic starting points, best cost kept),
then divide every ping by it: Î(z) = I(z) / f(z) (eq. 4.5). The result is dimensionless,
≈ 1 on average seabed. ``block`` fits one model per block of pings instead of one for the
whole waterfall (the thesis's "future work": the single-ping model breaks when the
altitude changes).

Internally the fit runs on u = z / n (n samples per side) so the exponents are O(1); the
reported b, d are per sample (as the thesis prints them). The pair (a, b), (c, d) is
ordered so that b ≤ d (the faster decay first).

Water column: the dark samples between nadir and the first seabed return are not echo
decay. ``fit_start="auto"`` starts the fit at the first return detected on the fit
profile (:func:`first_return_index`); ``fit_start=0`` fits the whole ping as the thesis
did.

DCP — He, Sun & Tang's dark channel prior dehazing applied to the grey waterfall: dark
channel = grey-level erosion over a ``patch``×``patch`` window (``cv2.erode``), airlight A
= mean intensity of the brightest 0.1 % dark-channel pixels, transmission
t = 1 − ω·dark(I/A) refined with a guided filter (written here with ``cv2.boxFilter``;
``cv2.ximgproc`` is not in pip's headless OpenCV), clipped at t0, J = (I − A)/t + A.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slam.io.images import as_grey_float
from slam.io.waterfall import Waterfall, waterfall_from_image

_BOUND_EXP = 30.0  # |b|, |d| bound in units of 1/n (exp(±30) stays finite in float64)


@dataclass(frozen=True)
class MiraFit:
    """One fitted mixed-exponential model f(z) = a·e^(b z) + c·e^(d z), z in samples.

    a, c : amplitudes (intensity units of the input, ≥ 0).
    b, d : rates per sample (b ≤ d).
    start: first sample index used in the fit.
    cost : final robust cost of least_squares (dimensionless after scaling by f_scale).
    ping : row index of the ping (or block centre) that was fitted.
    """

    a: float
    b: float
    c: float
    d: float
    start: int
    cost: float
    ping: int

    def __call__(self, z: np.ndarray) -> np.ndarray:
        z = np.asarray(z, dtype=np.float64)
        return self.a * np.exp(self.b * z) + self.c * np.exp(self.d * z)


@dataclass(frozen=True)
class MiraResult:
    """normalized : (P, 2S) float32, Î = I / f (dimensionless).
    port, starboard : one MiraFit per block (a single one without ``block``).
    block_rows : (n_blocks, 2) int, [first, last+1) rows each model applies to."""

    normalized: np.ndarray
    port: tuple[MiraFit, ...]
    starboard: tuple[MiraFit, ...]
    block_rows: np.ndarray


def _model(p: np.ndarray, u: np.ndarray) -> np.ndarray:
    return p[0] * np.exp(p[1] * u) + p[2] * np.exp(p[3] * u)


def _loglin(u: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """Least-squares line through log(y) → (amplitude, rate) of one exponential."""
    pos = y > 0
    if pos.sum() < 2:
        return float(max(np.mean(y), 1e-12)), 0.0
    rate, log_amp = np.polyfit(u[pos], np.log(y[pos]), 1)
    return float(np.exp(log_amp)), float(np.clip(rate, -_BOUND_EXP, _BOUND_EXP))


def first_return_index(profile: np.ndarray, *, smooth: int = 15, fraction: float = 0.25) -> int:
    """Index of the first seabed return in a near-range-first profile (or 0).

    The profile is median-smoothed over ``smooth`` samples; the water column is where it
    stays below ``fraction`` × its 90th percentile. Leading saturated/transmit samples
    (above the threshold before any dark sample) are skipped. Returns 0 when no dark
    water column is found.
    """
    from scipy.ndimage import median_filter

    y = median_filter(
        np.asarray(profile, dtype=np.float64), size=max(1, int(smooth)), mode="nearest"
    )
    thr = fraction * np.percentile(y, 90)
    below = np.flatnonzero(y < thr)
    if below.size == 0:
        return 0
    after = np.flatnonzero(y[below[0] :] >= thr)
    return int(below[0] + after[0]) if after.size else 0


def seabed_mask(waterfall: Waterfall, *, smooth: int = 15, fraction: float = 0.25) -> np.ndarray:
    """(P, 2S) bool: True from each ping's first seabed return outward, on both sides.

    Vectorized form of :func:`first_return_index` (row-wise median smoothing, threshold
    ``fraction`` × the row's 90th percentile, leading saturated samples skipped). Rows
    without a detectable water column are all True.
    """
    from scipy.ndimage import median_filter

    s = waterfall.samples_per_side
    img = as_grey_float(waterfall.intensity, name="waterfall.intensity").astype(np.float64)
    out = np.empty(img.shape, dtype=bool)
    for side, cols in ((img[:, :s][:, ::-1], slice(None, s)), (img[:, s:], slice(s, None))):
        y = median_filter(side, size=(1, max(1, int(smooth))), mode="nearest")
        thr = fraction * np.percentile(y, 90, axis=1, keepdims=True)
        below = y < thr
        has_below = below.any(axis=1)
        first_below = np.argmax(below, axis=1)
        idx = np.arange(s)[None, :]
        above_after = (~below) & (idx >= first_below[:, None])
        has_ret = has_below & above_after.any(axis=1)
        first_ret = np.where(has_ret, np.argmax(above_after, axis=1), 0)
        m = idx >= first_ret[:, None]
        out[:, cols] = m[:, ::-1] if cols.stop == s else m
    return out


def fit_mixed_exponential(
    profile: np.ndarray,
    *,
    start: int = 0,
    loss: str = "soft_l1",
    ping: int = -1,
    signed: bool = False,
) -> MiraFit:
    """Fit f(z) = a·e^(b z) + c·e^(d z) to a near-range-first profile, z = 0..n−1 samples.

    Bounded nonlinear least squares (``scipy.optimize.least_squares``, trust-region
    reflective) on samples ``start:``; amplitudes in [0, 100·max], rates in
    [−30/n, 30/n] per sample. Starting points: two-segment log-linear fits (near half,
    far half) and a single log-linear fit split into two; the lowest final cost wins.

    ``signed=True`` lets the amplitudes be negative too (a − c·e^(dz) differences model
    the rise-then-decay of a ping whose grazing-angle gain rises near nadir); the thesis's
    fits have positive amplitudes (default).

    Raises ValueError when the profile is empty, non-finite, has fewer than 8 samples
    after ``start`` or no positive sample.
    """
    from scipy.optimize import least_squares

    y_all = np.asarray(profile, dtype=np.float64).reshape(-1)
    n = y_all.size
    if n == 0 or not np.all(np.isfinite(y_all)):
        raise ValueError(f"MIRA profile must be non-empty and finite (size {n})")
    if not 0 <= start <= n - 8:
        raise ValueError(f"MIRA fit start {start} must be in [0, {n - 8}] for {n} samples")
    z = np.arange(start, n, dtype=np.float64)
    y = y_all[start:]
    ymax = float(np.max(y))
    if ymax <= 0:
        raise ValueError("MIRA profile has no positive sample to fit")
    u = z / n
    half = u.size // 2
    a1, b1 = _loglin(u[:half], y[:half])
    a2, b2 = _loglin(u[half:], y[half:])
    a0, b0 = _loglin(u, y)
    starts = [
        (a1, b1, a2, b2),
        (0.5 * a0, b0 - 1.0, 0.5 * a0, b0 + 1.0),
        (0.7 * a0, 2.0 * b0 - 1.0, 0.3 * a0, 0.5 * b0),
    ]
    if signed:
        starts.append((2.0 * a0, b0, -2.0 * a0, b0 - 10.0))
    amp_lo = -100.0 * ymax if signed else 0.0
    lo = np.array([amp_lo, -_BOUND_EXP, amp_lo, -_BOUND_EXP])
    hi = np.array([100.0 * ymax, _BOUND_EXP, 100.0 * ymax, _BOUND_EXP])
    f_scale = max(0.1 * float(np.median(np.abs(y))), 1e-9 * ymax)
    best = None
    for p0 in starts:
        p0 = np.clip(np.asarray(p0, dtype=np.float64), lo + 1e-12, hi - 1e-12)
        sol = least_squares(
            lambda p: (_model(p, u) - y) / f_scale,
            p0,
            bounds=(lo, hi),
            loss=loss,
            x_scale="jac",
            max_nfev=2000,
        )
        if best is None or sol.cost < best.cost:
            best = sol
    a, b, c, d = best.x
    if b > d:
        a, b, c, d = c, d, a, b
    return MiraFit(
        a=float(a),
        b=float(b / n),
        c=float(c),
        d=float(d / n),
        start=int(start),
        cost=float(best.cost),
        ping=int(ping),
    )


def _fit_profile(
    side: np.ndarray, rows: slice, k: int, average: int, fit_start, signed: bool
) -> MiraFit:
    half = average // 2
    lo, hi = max(rows.start, k - half), min(rows.stop, k - half + average)
    prof = side[lo:hi].mean(axis=0)
    if fit_start == "auto":
        start = min(first_return_index(prof), side.shape[1] - 8)
    else:
        start = int(fit_start)
    return fit_mixed_exponential(prof, start=start, ping=k, signed=signed)


def mira_normalize(
    waterfall: Waterfall | np.ndarray,
    *,
    ping: int | None = None,
    block: int | None = None,
    average: int = 1,
    fit_start: int | str = "auto",
    floor: float = 1e-3,
    signed: bool = False,
    blend: bool = True,
) -> MiraResult:
    """MIRA-normalize a side-scan waterfall (thesis eqs. 4.4–4.5).

    Parameters
    ----------
    waterfall : Waterfall, or a 2-D array (pings, 2·S) with port left, starboard right.
    ping : row k whose samples are fitted (default: the middle ping; the thesis used
        k = 500 of a longer recording). Ignored with ``block``.
    block : if given, fit one model per block of this many pings, on each block's centre ping.
    average : number of consecutive pings (centred on k) averaged into the fitted profile;
        1 reproduces the thesis's single-ping fit.
    fit_start : first sample index (from nadir) used in the fit, or ``"auto"`` (skip the
        water column of the fitted profile).
    floor : f is clipped below at ``floor`` × max f over the side, so far-range samples
        of a steeply decaying model are not divided by ~0.
    signed : allow negative amplitudes (see :func:`fit_mixed_exponential`).
    blend : with ``block``, interpolate the models linearly between block centres (no
        seams at block edges); False applies each block's model to its rows only.

    Returns MiraResult. Raises ValueError on bad input (non-2-D, odd width, non-finite,
    ping out of range, block < 1, average < 1).
    """
    if not isinstance(waterfall, Waterfall):
        waterfall = waterfall_from_image(as_grey_float(waterfall, name="waterfall"))
    img = as_grey_float(waterfall.intensity, name="waterfall.intensity")
    p, s = img.shape[0], waterfall.samples_per_side
    if s < 8:
        raise ValueError(f"MIRA needs at least 8 samples per side, got {s}")
    if average < 1:
        raise ValueError(f"average must be >= 1 ping, got {average}")
    if not (fit_start == "auto" or (isinstance(fit_start, int) and 0 <= fit_start <= s - 8)):
        raise ValueError(f"fit_start must be 'auto' or an int in [0, {s - 8}], got {fit_start!r}")
    if block is not None:
        if block < 1:
            raise ValueError(f"block must be >= 1 ping, got {block}")
        edges = np.arange(0, p, block)
        rows = np.stack([edges, np.minimum(edges + block, p)], axis=1)
        centres = (rows[:, 0] + rows[:, 1] - 1) // 2
    else:
        k = p // 2 if ping is None else int(ping)
        if not 0 <= k < p:
            raise ValueError(f"ping {ping} out of range [0, {p}) for a waterfall of {p} pings")
        rows = np.array([[0, p]])
        centres = np.array([k])
    port = img[:, :s][:, ::-1]  # near range first
    stbd = img[:, s:]
    z = np.arange(s, dtype=np.float64)
    out = np.empty_like(img)
    fits_p, fits_s = [], []
    models = {"port": [], "stbd": []}
    for (r0, r1), k in zip(rows, centres, strict=True):
        sl = slice(int(r0), int(r1))
        for name, side, fits in (("port", port, fits_p), ("stbd", stbd, fits_s)):
            fit = _fit_profile(side, sl, int(k), average, fit_start, signed)
            f = fit(z)
            models[name].append(np.maximum(f, floor * max(float(f.max()), 1e-30)))
            fits.append(fit)
    for name, side in (("port", port), ("stbd", stbd)):
        f_blocks = np.asarray(models[name])  # (n_blocks, S)
        if blend and f_blocks.shape[0] > 1:
            # linear interpolation between block centres (constant beyond the end ones)
            r = np.arange(p, dtype=np.float64)
            i1 = np.clip(np.searchsorted(centres, r), 1, centres.size - 1)
            i0 = i1 - 1
            w = np.clip((r - centres[i0]) / (centres[i1] - centres[i0]), 0.0, 1.0)[:, None]
            f_rows = (1.0 - w) * f_blocks[i0] + w * f_blocks[i1]
        else:
            block_of_row = np.repeat(np.arange(rows.shape[0]), rows[:, 1] - rows[:, 0])
            f_rows = f_blocks[block_of_row]
        norm = (side / f_rows).astype(np.float32)
        if name == "port":
            out[:, :s] = norm[:, ::-1]
        else:
            out[:, s:] = norm
    return MiraResult(normalized=out, port=tuple(fits_p), starboard=tuple(fits_s), block_rows=rows)


def _guided_filter(guide: np.ndarray, src: np.ndarray, radius: int, eps: float) -> np.ndarray:
    """He et al.'s grey guided filter (box-filter form); no library has it in headless cv2."""
    import cv2

    k = (2 * radius + 1, 2 * radius + 1)

    def box(x):
        return cv2.boxFilter(x, cv2.CV_64F, k, borderType=cv2.BORDER_REFLECT)

    mean_i, mean_p = box(guide), box(src)
    cov_ip = box(guide * src) - mean_i * mean_p
    var_i = box(guide * guide) - mean_i * mean_i
    a = cov_ip / (var_i + eps)
    b = mean_p - a * mean_i
    return box(a) * guide + box(b)


def dcp_normalize(
    image: np.ndarray,
    *,
    patch: int = 15,
    omega: float = 0.95,
    t0: float = 0.1,
    refine_radius: int = 30,
    refine_eps: float = 1e-3,
) -> np.ndarray:
    """Dark Channel Prior dehazing of a grey sonar image (baseline of thesis Ch. 4.1.3).

    The image is scaled by its maximum to [0, 1] first; returns float32 J in the same
    [0, 1] scale (clipped). A constant positive image is returned as ones (it is its own
    airlight, so J = I / max). Raises ValueError for bad images or parameters.
    """
    import cv2

    img = as_grey_float(image, name="image").astype(np.float64)
    if patch < 1 or not 0.0 < omega <= 1.0 or not 0.0 < t0 < 1.0:
        raise ValueError(
            f"DCP parameters out of range: patch={patch} (>= 1), omega={omega} (0, 1], t0={t0} (0, 1)"
        )
    m = float(img.max())
    if m <= 0:
        raise ValueError("DCP needs an image with positive values (max <= 0)")
    i = np.clip(img / m, 0.0, None)
    kernel = np.ones((patch, patch), np.uint8)
    dark = cv2.erode(i, kernel, borderType=cv2.BORDER_REFLECT)
    n_top = max(1, round(1e-3 * dark.size))
    idx = np.argpartition(dark.ravel(), -n_top)[-n_top:]
    airlight = max(float(i.ravel()[idx].mean()), 1e-12)
    t = 1.0 - omega * cv2.erode(i / airlight, kernel, borderType=cv2.BORDER_REFLECT)
    if refine_radius > 0:
        t = _guided_filter(i, t, refine_radius, refine_eps)
    t = np.maximum(t, t0)
    j = (i - airlight) / t + airlight
    return np.clip(j, 0.0, 1.0).astype(np.float32)

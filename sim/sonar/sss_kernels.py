"""Compiled per-ping steps of the side-scan sonar: the nadir probe's altitude and the
plain receive chain (no ``AcousticConfig.realism``) — speckle and noise, time-varying
gain and display compression, written straight into the ping's sample layout (port far
→ near, then starboard near → far).

The same floating-point operations in the same order as the numpy code they replace
(``SideScanSonar._altitude``'s median of the probe heights,
:func:`sim.sonar.acoustics.finish_samples`; speckle draws from the caller's numpy
Generator, in its order; ``log10`` stays numpy's, applied in place between the two
passes: numpy's result for an element does not depend on the array around it, while
libm's may differ in the last bit), so the outputs are the same bytes
(tests/sim/sonar/test_sss_kernels.py). Compiled by numba on first use, cached on disk.
"""

from __future__ import annotations

import numba
import numpy as np

SPECKLE_CODES = {"none": 0, "rayleigh": 1, "k": 2}


@numba.njit(cache=True, error_model="numpy")
def probe_altitude(dirs, dist, max_range):
    """Median (m) of the heights −d_z·dist of the probe rays ``dirs`` (P, 3) world frame,
    hit at ``dist`` (P,) m, within ``max_range`` (inf, no hit, is not); NaN if none. The
    median as np.median forms it (mean of the middle two for an even count)."""
    h = np.empty(dist.size)
    k = 0
    for i in range(dist.size):
        if dist[i] <= max_range:
            h[k] = -dirs[i, 2] * dist[i]
            k += 1
    if k == 0:
        return np.nan
    h = np.sort(h[:k])
    return h[k // 2] if k % 2 else (h[k // 2 - 1] + h[k // 2]) / 2.0


@numba.njit(cache=True, error_model="numpy")
def received(mean, noise, speckle, gamma, expo, tvg, floor_at):
    """Received intensity (rows · S,) float64 µPa² after TVG, in ping layout (row 0
    reversed, then row 1, …; rows ≤ 2) from the mean echo ``mean`` (rows, S): speckle 0
    (none) ``mean + noise``; 1 (Rayleigh) ``(mean + noise)·expo``; 2 (K) ``(mean·gamma
    + noise)·expo`` — ``gamma``, ``expo`` (rows, S) unit-mean draws — times ``tvg`` (S,);
    with ``floor_at`` > 0 clipped below at it (the argument of the display log)."""
    n_rows, s = mean.shape
    out = np.empty(n_rows * s)
    for q in range(n_rows):
        for k in range(s):
            m = mean[q, k]
            if speckle == 2:
                v = (m * gamma[q, k] + noise) * expo[q, k]
            elif speckle == 1:
                v = (m + noise) * expo[q, k]
            else:
                v = m + noise
            v *= tvg[k]
            if floor_at > 0.0:
                v = max(v, floor_at)
            out[(s - 1 - k) if q == 0 else q * s + k] = v
    return out


@numba.njit(cache=True, error_model="numpy")
def compressed(log10_i, floor_db, dynamic_range_db):
    """Display samples float32: (10·log10 I − floor_db) / dynamic_range_db clipped to
    [0, 1], from ``log10_i`` = log10 I (any shape, flattened)."""
    x = log10_i.ravel()
    out = np.empty(x.size, np.float32)
    for i in range(x.size):
        v = x[i] * 10.0
        v -= floor_db
        v /= dynamic_range_db
        out[i] = np.float32(min(max(v, 0.0), 1.0))
    return out


def ping_samples(mean, cfg, rng, tvg, noise):
    """Samples (rows · S,) float32 of a plain side-scan ping in ping layout from its mean
    echo (rows, S) µPa²: :func:`sim.sonar.acoustics.finish_samples` (``cfg``: the
    AcousticConfig, ``tvg`` (S,) its gain curve, ones for ``tvg = "none"``, ``noise``
    10^(noise_level_db/10)) followed by the port reversal, as two compiled passes."""
    code = SPECKLE_CODES[cfg.speckle]
    shape = mean.shape
    gamma = rng.gamma(cfg.k_shape, 1.0 / cfg.k_shape, size=shape) if code == 2 else _NONE
    expo = rng.standard_exponential(size=shape) if code else _NONE
    m = np.ascontiguousarray(mean, np.float64)
    if not cfg.log_compression:
        return received(m, noise, code, gamma, expo, tvg, 0.0).astype(np.float32)
    inten = received(m, noise, code, gamma, expo, tvg, 1e-30)
    np.log10(inten, out=inten)
    floor = cfg.display_floor_db
    if floor is None:
        floor = cfg.source_level_db + cfg.lambert_mu_db - 60.0
    return compressed(inten, float(floor), float(cfg.dynamic_range_db))


_NONE = np.zeros((0, 0))

"""Speckle with the resolution cell, the sample spacing and the ping-to-ping overlap.

The received field of a range cell is a sum over the scatterers inside the pulse's
resolution cell δr = c/(2B): complex circular Gaussian. Sampling it every Δr (the bin
width) gives

* along range, correlated samples when δr > Δr (neighbouring samples share scatterers);
* inside one sample, L ≈ Δr/δr independent looks when δr < Δr (the sample integrates
  several cells), so the intensity is Γ(L, 1/L) × mean, amplitude CV below Rayleigh's 0.523;
* across pings, correlation when consecutive pings' along-track footprints overlap: with
  a Gaussian two-way along-track beam of −3 dB width β at range r (footprint σ_x =
  rβ/(2√(2 ln 2))) and a ping-to-ping advance d, the complex correlation is
  ρ(r) = exp(−d²/(4σ_x²)) (overlap integral of the two illuminations).

Model (vectorised, no per-sample loops): white complex Gaussian on a grid of M sub-samples
per bin, convolved along range with a Gaussian pulse envelope of −3 dB width δr, carried
from ping to ping by z_p = ρ z_{p−1} + √(1 − ρ²) ε_p (AR(1) per sub-sample), then |z|²
averaged over the M sub-samples of each bin. Normalised so E|·|² = 1 per bin.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import convolve1d

MAX_SUBSAMPLES = 8


def subsamples(bin_width: float, range_cell: float) -> int:
    """Sub-samples per bin: enough to resolve a cell δr inside a bin Δr (2 per cell)."""
    return int(np.clip(np.ceil(2.0 * bin_width / range_cell), 1, MAX_SUBSAMPLES))


def pulse_kernel(range_cell: float, sub_width: float) -> np.ndarray:
    """Unit-energy Gaussian amplitude envelope exp(−x²/2s²) whose intensity exp(−x²/s²)
    has −3 dB width ``range_cell`` m (s = δr / (2√ln 2)), sampled at ``sub_width`` m."""
    s = range_cell / (2.0 * np.sqrt(np.log(2.0)))
    half = max(1, int(np.ceil(3.0 * s / sub_width)))
    x = np.arange(-half, half + 1) * sub_width
    k = np.exp(-0.5 * (x / s) ** 2)
    return k / np.sqrt(np.sum(k * k))


def ping_correlation(r: np.ndarray, advance: float, beamwidth: float) -> np.ndarray:
    """Complex speckle correlation ρ(r) between consecutive pings for an along-track
    advance ``advance`` m and a two-way −3 dB beamwidth ``beamwidth`` rad."""
    sx = np.maximum(r, 1e-3) * beamwidth / (2.0 * np.sqrt(2.0 * np.log(2.0)))
    return np.exp(-(advance**2) / (4.0 * sx * sx))


class CorrelatedSpeckle:
    """Speckle factors (rows, bins) of unit mean for successive pings of one sonar.

    bin_width, range_cell (m); ranges (bins,) m; beamwidth (rad, along-track two-way
    −3 dB); overlap: carry the field across pings (False: independent pings)."""

    def __init__(self, bin_width, range_cell, ranges, beamwidth, overlap=True):
        self.m = subsamples(bin_width, range_cell)
        self.kernel = pulse_kernel(range_cell, bin_width / self.m)
        self.r_sub = np.repeat(np.asarray(ranges, float), self.m)
        self.beamwidth = float(beamwidth)
        self.overlap = bool(overlap)
        self._z = None
        self._pos = None

    def _white(self, shape, rng):
        z = rng.standard_normal((2, *shape), dtype=np.float32) * np.float32(np.sqrt(0.5))
        return z[0] + 1j * z[1]

    def factors(self, n_rows: int, position: np.ndarray, rng: np.random.Generator):
        """Draw the next ping's (n_rows, bins) speckle factors; ``position`` (3,) world m of
        the transducer (its advance since the last ping sets ρ)."""
        shape = (n_rows, self.r_sub.size)
        eps = self._white(shape, rng)
        if self.overlap and self._z is not None and self._z.shape == shape:
            d = float(np.linalg.norm(np.asarray(position)[:2] - self._pos[:2]))
            rho = ping_correlation(self.r_sub, d, self.beamwidth)[None, :]
            z = rho * self._z + np.sqrt(1.0 - rho * rho) * eps
        else:
            z = eps
        self._z = z
        self._pos = np.asarray(position, float).copy()
        f = convolve1d(z.real, self.kernel, axis=1, mode="reflect") + 1j * convolve1d(
            z.imag, self.kernel, axis=1, mode="reflect"
        )
        inten = (f.real**2 + f.imag**2).reshape(n_rows, -1, self.m).mean(axis=2)
        return inten

"""A statistical side-scan waterfall with known parameters (no ray casting).

Used to test the calibration (its true parameters are known, so a fit must recover them)
and as a fast stand-in model. Per side, near range first: ``water_column_fraction`` of the
samples hold water column (exponential intensity ``water_column_db`` below the seabed
mean), the rest seabed = gain × texture × speckle, clipped at full scale 1:

* texture: a Gaussian field smoothed over ``texture_cell`` samples and pings, scaled to
  ``texture_db`` rms in dB, converted to a unit-mean linear factor;
* speckle: |z|² of complex Gaussian fields with AR(1) correlation ``corr_range`` along
  range and ``corr_ping`` across pings, ``looks`` of them averaged (a fractional look is
  added with its fraction as weight, so the result is continuous in ``looks``; unit mean;
  one look is Rayleigh amplitude);
* gain: the seabed mean intensity re full scale, ``gain_db``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import uniform_filter
from scipy.signal import lfilter

from slam.realism.calibration import Parameter

#: clip level of the model's intensity (give it to the statistics as ``full_scale``).
FULL_SCALE = 1.0
#: the model's free parameters with bounds and start values.
PARAMETERS = (
    Parameter("gain_db", -30.0, 0.0, -12.0),
    Parameter("texture_db", 0.0, 6.0, 1.0),
    Parameter("corr_range", 0.0, 0.9, 0.3),
    Parameter("corr_ping", 0.0, 0.9, 0.3),
    Parameter("water_column_db", -70.0, -10.0, -30.0),
    Parameter("looks", 1.0, 6.0, 1.5),
)
_MAX_LOOKS = 6


def ar1_field(
    shape: tuple[int, int], phi_ping: float, phi_range: float, rng: np.random.Generator
) -> np.ndarray:
    """Unit-variance real Gaussian field with separable stationary AR(1) correlation:
    lag-1 ``phi_range`` along axis 1 and ``phi_ping`` along axis 0."""
    x = rng.standard_normal(shape)
    for axis, phi in ((1, phi_range), (0, phi_ping)):
        zshape = list(shape)
        zshape[axis] = 1
        zi = phi * rng.standard_normal(zshape)
        x, _ = lfilter([np.sqrt(1.0 - phi * phi)], [1.0, -phi], x, axis=axis, zi=zi)
    return x


@dataclass(frozen=True)
class StatisticalSideScan:
    """The model; call it with a dict of PARAMETERS values to get a (P, 2S) waterfall."""

    pings: int = 96
    samples_per_side: int = 384
    water_column_fraction: float = 0.2
    texture_cell: int = 8
    seed: int = 0

    def __post_init__(self) -> None:
        if self.pings < 32 or self.samples_per_side < 64:
            raise ValueError(
                f"StatisticalSideScan needs >= 32 pings and >= 64 samples, got "
                f"{self.pings} x {self.samples_per_side}"
            )
        if not 0.05 <= self.water_column_fraction <= 0.8:
            raise ValueError(
                f"water_column_fraction = {self.water_column_fraction}; allowed 0.05 .. 0.8"
            )

    @staticmethod
    def _speckle(shape, v: dict[str, float], rng: np.random.Generator) -> np.ndarray:
        """Unit-mean speckle intensity of ``v["looks"]`` averaged correlated looks (the
        draws do not depend on ``looks``: always _MAX_LOOKS fields, weighted)."""
        w = np.clip(v["looks"] - np.arange(_MAX_LOOKS), 0.0, 1.0)
        out = np.zeros(shape)
        for k in range(_MAX_LOOKS):
            re, im = (ar1_field(shape, v["corr_ping"], v["corr_range"], rng) for _ in "ri")
            out += w[k] * (re * re + im * im) / 2.0
        return out / w.sum()

    def __call__(self, values: dict[str, float]) -> np.ndarray:
        v = {p.name: p.initial for p in PARAMETERS} | dict(values)
        unknown = set(v) - {p.name for p in PARAMETERS}
        if unknown:
            raise ValueError(f"unknown parameter(s) {sorted(unknown)}")
        rng = np.random.default_rng(self.seed)
        p, s = self.pings, self.samples_per_side
        nw = round(self.water_column_fraction * s)
        sides = []
        for _ in range(2):
            g = uniform_filter(rng.standard_normal((p, s - nw)), self.texture_cell, mode="wrap")
            g /= g.std()
            tex = 10.0 ** (v["texture_db"] * g / 10.0)
            tex /= tex.mean()
            speckle = self._speckle((p, s - nw), v, rng)
            seabed = 10.0 ** (v["gain_db"] / 10.0) * tex * speckle
            wc = rng.exponential(10.0 ** ((v["gain_db"] + v["water_column_db"]) / 10.0), (p, nw))
            sides.append(np.minimum(np.concatenate([wc, seabed], axis=1), FULL_SCALE))
        return np.concatenate([sides[0][:, ::-1], sides[1]], axis=1)

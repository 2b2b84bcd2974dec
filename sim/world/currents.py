"""Ocean current: a uniform flow plus an optional seeded, spatially and temporally varying
horizontal field.

The varying part is the sum of K random Fourier modes of a stream function
ψ(x, y, t) = Σ_k a_k sin(k_k·x − ω_k t + φ_k), so (u, v) = (∂ψ/∂y, −∂ψ/∂x) is exactly
divergence-free (no spurious up/down-welling) — a standard synthetic-turbulence
construction (Kraichnan 1970). Wavelengths scatter around ``length_scale`` and periods
around ``time_scale``; amplitudes are normalized so the rms speed of the varying part
is ``variation``. Evaluated for all vehicles in one vectorized call.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class CurrentSpec:
    """velocity (3,) uniform world-frame current, m/s; variation rms of the varying part,
    m/s (0 = uniform); length_scale m; time_scale s; n_modes; seed."""

    velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    variation: float = 0.0
    length_scale: float = 50.0
    time_scale: float = 600.0
    n_modes: int = 16
    seed: int = 0

    def __post_init__(self) -> None:
        v = np.asarray(self.velocity, dtype=float)
        if v.shape != (3,) or not np.isfinite(v).all() or np.linalg.norm(v) > 10.0:
            raise ValueError(
                f"current.velocity must be 3 finite m/s values with |v| <= 10, got {self.velocity!r}"
            )
        for name in ("variation", "length_scale", "time_scale"):
            x = float(getattr(self, name))
            if not np.isfinite(x) or x < 0 or (name != "variation" and x == 0):
                raise ValueError(
                    f"current.{name} must be {'>= 0' if name == 'variation' else '> 0'}, got {x!r}"
                )
        if int(self.n_modes) < 1:
            raise ValueError(f"current.n_modes must be >= 1, got {self.n_modes!r}")


class CurrentField:
    def __init__(self, spec: CurrentSpec):
        self.spec = spec
        self.uniform = np.asarray(spec.velocity, dtype=float)
        self.varying = spec.variation > 0
        self.is_zero = not self.varying and not np.any(self.uniform)
        rng = np.random.default_rng(spec.seed)
        k = spec.n_modes
        lam = spec.length_scale * np.exp(rng.normal(0.0, 0.3, k))
        ang = rng.uniform(0, 2 * np.pi, k)
        kmag = 2 * np.pi / lam
        self.kx = kmag * np.cos(ang)
        self.ky = kmag * np.sin(ang)
        self.omega = (
            2
            * np.pi
            / (spec.time_scale * np.exp(rng.normal(0.0, 0.3, k)))
            * rng.choice([-1.0, 1.0], k)
        )
        self.phase = rng.uniform(0, 2 * np.pi, k)
        a = rng.normal(0.0, 1.0, k)
        # speed of mode k has rms |a_k| |k_k| / sqrt(2); normalise the sum to `variation`
        rms = np.sqrt(np.sum((a * kmag) ** 2) / 2.0)
        self.amp = a * (spec.variation / rms) if rms > 0 else a * 0
        # (K, 5) modes k_x, k_y, ω, φ, amplitude, the layout of sim.physics_kernel (no
        # rows when the current is uniform)
        self.modes = np.ascontiguousarray(
            np.column_stack([self.kx, self.ky, self.omega, self.phase, self.amp])[
                : k if self.varying else 0
            ]
        )

    def velocity(self, pos: np.ndarray, t: float) -> np.ndarray:
        """World-frame current (N, 3) at positions (N, 3) and time t."""
        n = pos.shape[0]
        out = np.empty((n, 3))
        out[:] = self.uniform
        if self.varying:
            arg = pos[:, :1] * self.kx + pos[:, 1:2] * self.ky - self.omega * t + self.phase
            c = np.cos(arg) * self.amp  # (N, K)
            out[:, 0] += c @ self.ky  # u = ∂ψ/∂y
            out[:, 1] -= c @ self.kx  # v = −∂ψ/∂x
        return out

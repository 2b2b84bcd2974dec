"""Thrusters and control surfaces: thrust curve, saturation, first-order lag, allocation.

Every actuator channel of every vehicle in a world lives in one ``ThrusterBank`` (flat
arrays), so a physics step costs a handful of numpy operations for all vehicles.

Propeller channel (Fossen 2011, propulsion chapter; Yoerger, Cooke & Slotine 1990): the normalized
command u ∈ [−1, 1] (saturated by clipping) sets the demanded normalized shaft speed;
the actual speed n follows it with a first-order lag of time constant T (discretized
exactly for a command held over the step: n ← u + (n − u) e^(−dt/T)), and thrust is the
quadratic propeller curve  F = F_fwd n|n| (n ≥ 0) or F_rev n|n| (n < 0) along the
thruster's axis (the MJCF site's z axis).

Fin channel (pair of control surfaces moving together): u sets the demanded deflection
δ = u δ_max with the same lag; the lift  F = ½ ρ S C_Lα δ u_r|u_r|  acts along the
site's z axis (the lift direction for positive deflection), u_r the surge speed through
the water. ``max_forward`` stores ½ ρ S C_Lα δ_max in N/(m/s)².

Allocation (``allocate``): least-squares (pseudo-inverse) solution of B_eff f = τ over the
degrees of freedom the vehicle controls, B_eff the 6×k configuration matrix (columns
[d; r × d] per channel, fin columns scaled by u_r|u_r|), with saturation handled by the
redistributed pseudo-inverse (Bodson 2002, J. Guid. Control Dyn. 25(4)): channels whose
force exceeds their limit are fixed at the limit and the rest of the demand is solved
again over the free channels (at most k passes). Channel forces are then mapped back
through the inverse thrust curve to commands in [−1, 1].

Fin incidence is limited to the stall angle (``FIN_STALL_RAD``): beyond it the lift stops
growing (the cross-flow drag of the hull takes over).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

KINDS = ("propeller", "fin")
FIN_STALL_RAD = 0.35  # incidence beyond which the fin lift saturates (≈ 20°, low aspect ratio)
PINV_RCOND = 1e-6  # allocation pseudo-inverse: singular values below this × the largest are dropped
SCALED_COND_MAX = 1e3  # fin-scaled allocation matrices reuse pinv(B0) up to this condition bound


@dataclass(frozen=True)
class ThrusterSpec:
    """One actuator channel. position/direction are body-frame (filled from the MJCF site).

    kind            : "propeller" or "fin".
    max_forward     : propeller: thrust at u = +1, N; fin: ½ρ S C_Lα δ_max, N/(m/s)².
    max_reverse     : propeller: thrust magnitude at u = −1, N (fins: same as forward).
    time_constant   : first-order lag of shaft speed / fin deflection, s.
    """

    name: str
    kind: str
    max_forward: float
    max_reverse: float
    time_constant: float
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    direction: tuple[float, float, float] = (1.0, 0.0, 0.0)
    lift_gain: float = 0.0  # fins: ½ ρ S C_Lα, N/(m/s)² per rad of incidence

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(
                f"thruster {self.name!r} kind must be one of {KINDS}, got {self.kind!r}"
            )
        for f in ("max_forward", "max_reverse", "time_constant"):
            v = getattr(self, f)
            if not np.isfinite(v) or v <= 0:
                raise ValueError(f"thruster {self.name!r} {f} must be > 0, got {v!r}")
        d = np.asarray(self.direction, dtype=float)
        if d.shape != (3,) or not np.isfinite(d).all() or np.linalg.norm(d) < 1e-9:
            raise ValueError(
                f"thruster {self.name!r} direction must be a non-zero 3-vector, got {self.direction!r}"
            )

    def column(self) -> np.ndarray:
        """Configuration column [d; r × d] (6,) per unit channel force."""
        d = np.asarray(self.direction, dtype=float)
        d = d / np.linalg.norm(d)
        return np.concatenate([d, np.cross(np.asarray(self.position, dtype=float), d)])


class ThrusterBank:
    """All channels of all vehicles; ``owner[i]`` is the vehicle index of channel i."""

    def __init__(self, specs_per_vehicle: list[list[ThrusterSpec]], dt: float):
        specs = [s for vs in specs_per_vehicle for s in vs]
        self.n_vehicles = len(specs_per_vehicle)
        self.n = len(specs)
        self.owner = np.array(
            [i for i, vs in enumerate(specs_per_vehicle) for _ in vs], dtype=np.intp
        )
        self.offsets = np.cumsum([0] + [len(vs) for vs in specs_per_vehicle]).astype(np.intp)
        self.is_fin = np.array([s.kind == "fin" for s in specs], dtype=bool)
        self.any_fin = bool(self.is_fin.any())
        self.f_fwd = np.array([s.max_forward for s in specs])
        self.f_rev = np.array([s.max_reverse for s in specs])
        self.tc = np.array([s.time_constant for s in specs])
        self.lift_gain = np.array([s.lift_gain for s in specs])
        # rows: command | level (lagged normalized shaft speed / deflection) | force N |
        # lag decay per step; the named arrays are views, updated in place (the compiled
        # step of sim.physics_kernel advances them through ``state``)
        self.state = np.zeros((4, self.n))
        self.command, self.level, self.force, self.decay = self.state
        self.set_dt(dt)
        cols = [s.column() for s in specs]
        self.columns = np.array(cols).reshape(self.n, 6)
        # stacked configuration: tau (N,6) = sum over channels of column * force
        self._scatter = np.zeros((self.n_vehicles, self.n))
        self._scatter[self.owner, np.arange(self.n)] = 1.0
        self._pinv_cache: dict = {}
        self._fin_idx = np.flatnonzero(self.is_fin)
        self._fin_owner = self.owner[self._fin_idx]
        self._fin_cols = self.columns[self._fin_idx]
        self._fin_gain = self.f_fwd[self._fin_idx]
        self._fin_lift = self.lift_gain[self._fin_idx]
        # the (k, 10) channel table of sim.physics_kernel: column | F_fwd | F_rev | lift | fin
        self.table = np.ascontiguousarray(
            np.column_stack(
                [self.columns, self.f_fwd, self.f_rev, self.lift_gain, self.is_fin.astype(float)]
            ).reshape(self.n, 10)
        )

    def set_dt(self, dt: float) -> None:
        self.decay[:] = np.exp(-float(dt) / self.tc)

    def set_commands(self, vehicle: int, u: np.ndarray) -> None:
        lo, hi = int(self.offsets[vehicle]), int(self.offsets[vehicle + 1])
        # a handful of channels: Python floats are cheaper than numpy calls per element
        vals = np.asarray(u, dtype=float).reshape(-1).tolist()
        if len(vals) != hi - lo or not all(math.isfinite(v) for v in vals):
            raise ValueError(
                f"thruster commands must be {hi - lo} finite numbers in [-1, 1], got {u!r}"
            )
        c = self.command
        for j, v in enumerate(vals):
            c[lo + j] = min(max(v, -1.0), 1.0)  # finite: the same as np.clip

    def step(self, nu_r: np.ndarray | None) -> np.ndarray:
        """Advance the lag one step; return the per-vehicle body wrench (N, 6).

        nu_r (N, 6): body-frame velocity relative to the water (needed only when fins
        exist). A fin's lift is F = ½ρ S C_Lα (δ u_r|u_r| − |u_r| w_f), where
        w_f = n·(v_r + ω × r) = column · ν_r is the flow across the fin (incidence
        α ≈ w_f / u_r): deflection lift plus the passive stabilizing lift of the fin."""
        c = self.command
        lv = c + (self.level - c) * self.decay
        self.level[:] = lv
        f = lv * np.abs(lv) * np.where(lv >= 0.0, self.f_fwd, self.f_rev)
        if self._fin_idx.size and nu_r is not None:
            nu = nu_r[self._fin_owner]  # (n_fin, 6)
            u = nu[:, 0]
            au = np.abs(u)
            lim = FIN_STALL_RAD * au  # incidence w_f/|u| limited to the stall angle
            cross = np.minimum(np.maximum((self._fin_cols * nu).sum(axis=1), -lim), lim)
            f[self._fin_idx] = au * (
                self._fin_gain * lv[self._fin_idx] * u - self._fin_lift * cross
            )
        self.force[:] = f
        return (self._scatter * f) @ self.columns

    def _pinv(
        self, vehicle: int, dkey: bytes, sel: np.ndarray, b: np.ndarray, scale: np.ndarray | None
    ) -> np.ndarray:
        """Pseudo-inverse (rcond ``PINV_RCOND``) of b = B0 diag(scale[sel]), B0 the vehicle's
        unscaled configuration rows ``dkey`` and channels ``sel``; scale None: b = B0.

        pinv(B0) is computed once per (vehicle, dofs, channels). Finless (scale None) it
        is the answer, bit for bit. With fins, when B0 has full column rank and
        diag(scale) keeps b well conditioned (σ_min(B0) min|s| > σ_max(B0) max|s| /
        ``SCALED_COND_MAX``, so no singular value of b falls under the rcond cutoff),
        pinv(B0 D) = D⁻¹ pinv(B0) exactly and differs from ``np.linalg.pinv(b)`` only by
        rounding (≲ 1e-13 relative); otherwise b's own pseudo-inverse is computed."""
        key = (vehicle, dkey, sel.tobytes())
        hit = self._pinv_cache.get(key)
        if hit is None:
            cols = self.columns[self.offsets[vehicle] : self.offsets[vehicle + 1]].T
            b0 = cols[np.frombuffer(dkey, dtype=bool)][:, sel]
            sv = np.linalg.svd(b0, compute_uv=False)
            full = b0.shape[1] <= b0.shape[0] and sv[-1] > 0.0
            hit = (np.linalg.pinv(b0, rcond=PINV_RCOND), full, sv[0], sv[-1] if full else 0.0)
            self._pinv_cache[key] = hit
        pinv0, full, smax, smin = hit
        if scale is None:
            return pinv0
        d = scale[sel]
        if (d == 1.0).all():  # only propellers among the channels: b is B0
            return pinv0
        a = np.abs(d)
        if full and smin * a.min() * SCALED_COND_MAX > smax * a.max():
            return pinv0 / d[:, None]
        return np.linalg.pinv(b, rcond=PINV_RCOND)

    def allocate(
        self, vehicle: int, tau: np.ndarray, dofs: np.ndarray, speed_sq: float
    ) -> np.ndarray:
        """Commands (k,) in [−1, 1] for a body wrench demand tau (6,) of one vehicle.

        dofs: bool (6,) mask of the degrees of freedom the vehicle controls (the others
        are left to the least-squares residual instead of distorting the controlled ones).
        """
        lo, hi = self.offsets[vehicle], self.offsets[vehicle + 1]
        cols = self.columns[lo:hi].T.copy()  # (6, k)
        fin = self.is_fin[lo:hi]
        cols[:, fin] *= speed_sq
        b = cols[dofs]
        t = np.asarray(tau, dtype=float)[dofs]
        k = hi - lo
        # limits per channel: propellers F_fwd / −F_rev (N); fins ±g δ_max, the fin force per
        # unit u_r|u_r| (the speed factor is in the scaled columns)
        upper = self.f_fwd[lo:hi].copy()
        lower = -self.f_rev[lo:hi]
        f = np.zeros(k)
        free = np.ones(k, dtype=bool)
        scale = np.where(fin, speed_sq, 1.0) if fin.any() else None
        dkey = dofs.tobytes()
        for it in range(k):  # redistributed pseudo-inverse
            if it == 0:  # all channels free
                f = self._pinv(vehicle, dkey, free, b, scale) @ t
            else:
                resid = t - b[:, ~free] @ f[~free]
                f[free] = self._pinv(vehicle, dkey, free, b[:, free], scale) @ resid
            over = free & ((f > upper) | (f < lower))
            if not over.any():
                break
            f[over] = np.clip(f[over], lower[over], upper[over])
            free &= ~over
            if not free.any():
                break
        # inverse thrust curve: propellers F = F_max n|n|; fins F = g δ u_r|u_r| (g in cols)
        u = np.empty(k)
        prop = ~fin
        fmax = np.where(f[prop] >= 0.0, self.f_fwd[lo:hi][prop], self.f_rev[lo:hi][prop])
        u[prop] = np.sign(f[prop]) * np.sqrt(np.abs(f[prop]) / fmax)
        u[fin] = f[fin] / self.f_fwd[lo:hi][fin]
        return np.clip(u, -1.0, 1.0)

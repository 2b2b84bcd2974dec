"""Fossen-style 6-DOF hydrodynamics that MuJoCo does not provide, vectorized over vehicles.

Model (Fossen 2011, *Handbook of Marine Craft Hydrodynamics and Motion Control*, the 6-DOF
equations of motion with the current acting through the relative velocity ν_r = ν − ν_c):

    M_RB ν̇ + C_RB(ν) ν + M_A ν̇_r + C_A(ν_r) ν_r + D(ν_r) ν_r + g(η) = τ

in the body frame (x forward, y port, z up) about the centre of gravity, which is the
origin of every vehicle body (so M_RB = diag(m, m, m, I_xx, I_yy, I_zz) with principal
axes along the body axes). M_A and the damping matrices are diagonal (the vehicles are
symmetric about two planes to the accuracy of the coefficients used).

- ``g(η)``: weight W = m g at the CG and buoyancy B = ρ V g at the centre of buoyancy
  r_B (body frame) — the righting moment r_B × f_B. Buoyancy falls linearly with the
  submerged fraction of the vehicle height when the vehicle breaks the surface.
- ``D(ν_r) ν_r = (D_l + D_q |ν_r|) ν_r`` (linear + quadratic, element-wise).
- ``C_A(ν_r) ν_r`` = [ω × (A_v v_r); v_r × (A_v v_r) + ω × (A_ω ω)] (Fossen 2011, ch. 6, for a
  diagonal M_A), which carries the Munk moment.
- Current: irrotational and, locally, constant in the world frame, so in the body frame
  ν̇_c = −ω × v_c (Fossen 2011, ocean-current chapter); the M_A ν̇_c term is included. The temporal and
  spatial derivative of a varying current field is not (its scales are ≥ tens of metres
  and minutes: the omitted Froude–Krylov force is < 1 % of the damping there).

How added mass enters MuJoCo (exact, not lagged): MuJoCo integrates the rigid body
M_RB ν̇ = f_applied + f_gravity − C_RB(ν) ν. We solve the full model for the body
acceleration ν̇* = (M_RB + M_A)⁻¹ (τ + g + M_A ν̇_c − C_RB ν − C_A ν_r − D ν_r) and apply

    f_applied = M_RB ν̇* + C_RB(ν) ν − f_gravity

through ``xfrc_applied`` (at the CoM = body origin), so MuJoCo's own step produces
exactly ν̇*. Unlike the common "last step's acceleration times M_A" trick (Gazebo,
UUV Simulator) this has no one-step lag and no instability for light vehicles with large
added mass (M_A / m > 1 makes the lagged version diverge). Contacts act through the rigid
body mass only (a collision impulse does not see the added mass) — accepted.

Integration: MuJoCo's semi-implicit Euler at the world timestep (default 0.01 s); the
hydrodynamic forces are evaluated at the start of each step (``mj_step1`` → forces →
``mj_step2``), i.e. damping is explicit. Stability needs h·(∂D/∂ν)/(m + m_A) ≪ 2 and
h·ω_n ≪ 2; for the five vehicles at h = 0.01 s the largest values are 0.22 (SAGA surge,
after its open-frame added mass; at 3 m/s, beyond its top speed) and 0.06 (Alister 9 and
SAGA roll).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import elliprd

from sim.physics_kernel import wrench_batch

_DOF = ("surge", "sway", "heave", "roll", "pitch", "yaw")


def _vec(name: str, value, n: int, *, positive: bool = False, nonneg: bool = False) -> np.ndarray:
    a = np.asarray(value, dtype=float)
    if a.shape != (n,) or not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be {n} finite numbers, got {value!r}")
    if positive and np.any(a <= 0):
        raise ValueError(f"{name} must be > 0 in every component, got {value!r}")
    if nonneg and np.any(a < 0):
        raise ValueError(f"{name} must be >= 0 in every component, got {value!r}")
    a.setflags(write=False)
    return a


def ellipsoid_added_mass(a: float, b: float, c: float, rho: float) -> np.ndarray:
    """Added mass diag [A11, A22, A33, A44, A55, A66] of a solid ellipsoid, kg and kg·m².

    Semi-axes a, b, c along body x, y, z (m), fluid density rho (kg/m³). Lamb (1932,
    *Hydrodynamics*, ch. V) / Imlay (1961, DTMB report 1528) for an ellipsoid in
    unbounded ideal fluid:
        α0 = a b c ∫ dλ / ((a²+λ) Δ),  Δ = √((a²+λ)(b²+λ)(c²+λ))  (β0, γ0 cyclically),
        A11 = α0 / (2 − α0) · ρV,
        A44 = ρV/5 · (b² − c²)² (γ0 − β0) / (2(b² − c²) + (b² + c²)(β0 − γ0)),
    with α0 = (2/3) a b c R_D(b², c², a²) (Carlson's symmetric integral, scipy's elliprd).
    A sphere gives A11 = ρV/2 and zero rotational added inertia.
    """
    for nm, v in (("a", a), ("b", b), ("c", c), ("rho", rho)):
        if not np.isfinite(v) or v <= 0:
            raise ValueError(f"ellipsoid {nm} must be > 0, got {v!r}")
    vol = 4.0 / 3.0 * np.pi * a * b * c
    abc = a * b * c
    alpha = 2.0 / 3.0 * abc * elliprd(b * b, c * c, a * a)
    beta = 2.0 / 3.0 * abc * elliprd(c * c, a * a, b * b)
    gamma = 2.0 / 3.0 * abc * elliprd(a * a, b * b, c * c)
    m = rho * vol
    a11 = alpha / (2.0 - alpha) * m
    a22 = beta / (2.0 - beta) * m
    a33 = gamma / (2.0 - gamma) * m

    def rot(p2: float, q2: float, g_p: float, g_q: float) -> float:
        # (p² − q²)² (g_q − g_p) / (2(p² − q²) + (p² + q²)(g_p − g_q)); 0 when p == q
        d = p2 - q2
        if abs(d) < 1e-12 * max(p2, q2):
            return 0.0
        return m / 5.0 * d * d * (g_q - g_p) / (2.0 * d + (p2 + q2) * (g_p - g_q))

    a44 = rot(b * b, c * c, beta, gamma)
    a55 = rot(c * c, a * a, gamma, alpha)
    a66 = rot(a * a, b * b, alpha, beta)
    return np.array([a11, a22, a33, a44, a55, a66])


def strip_theory_quadratic_damping(
    length: float, width: float, height: float, cd: np.ndarray, rho: float, frontal: str = "box"
) -> np.ndarray:
    """Quadratic damping magnitudes [X_|u|u, …, N_|r|r] (N·s²/m², N·m·s²) from drag
    coefficients cd = (Cd_x, Cd_y, Cd_z) on the projected areas of a box or an elliptic
    cylinder envelope (``frontal`` = "box" or "ellipse" for the x-face of a torpedo).

    Translation: X = ½ ρ Cd_x A_x u|u| with A_x = W·H (box) or π/4·W·H (ellipse),
    A_y = L·H, A_z = L·W. Rotation by strip theory (cross-flow drag integrated along the
    body, the cross-flow principle in Fossen 2011, ch. 6): a strip at lever x moving at r·x gives
    N = ½ ρ Cd_y H ∫|x|³ dx = ½ ρ Cd_y H L⁴/32, likewise M with Cd_z W L⁴/32 and
    K = ½ ρ (Cd_z L W⁴ + Cd_y L H⁴)/32.
    """
    L, W, H = float(length), float(width), float(height)
    cx, cy, cz = (float(v) for v in cd)
    ax = (np.pi / 4.0 if frontal == "ellipse" else 1.0) * W * H
    half = 0.5 * rho
    return np.array(
        [
            half * cx * ax,
            half * cy * L * H,
            half * cz * L * W,
            half * (cz * L * W**4 + cy * L * H**4) / 32.0,
            half * cz * W * L**4 / 32.0,
            half * cy * H * L**4 / 32.0,
        ]
    )


@dataclass(frozen=True)
class HydroParams:
    """Rigid-body and hydrodynamic parameters of one vehicle (body frame at the CG).

    mass kg; inertia (3,) principal moments kg·m²; volume m³ displaced when fully
    submerged; r_cb (3,) centre of buoyancy relative to the CG, m; added_mass (6,) kg, kg·m²;
    linear_damping (6,) N·s/m, N·m·s; quadratic_damping (6,) N·s²/m², N·m·s²;
    height m (vertical extent used for the partial submergence at the surface).
    All damping values are magnitudes (the force opposes the relative velocity).
    """

    mass: float
    inertia: np.ndarray
    volume: float
    r_cb: np.ndarray
    added_mass: np.ndarray
    linear_damping: np.ndarray
    quadratic_damping: np.ndarray
    height: float

    def __post_init__(self) -> None:
        if not np.isfinite(self.mass) or self.mass <= 0:
            raise ValueError(f"mass must be > 0 kg, got {self.mass!r}")
        if not np.isfinite(self.volume) or self.volume <= 0:
            raise ValueError(f"volume must be > 0 m³, got {self.volume!r}")
        if not np.isfinite(self.height) or self.height <= 0:
            raise ValueError(f"height must be > 0 m, got {self.height!r}")
        object.__setattr__(self, "inertia", _vec("inertia", self.inertia, 3, positive=True))
        object.__setattr__(self, "r_cb", _vec("r_cb", self.r_cb, 3))
        object.__setattr__(self, "added_mass", _vec("added_mass", self.added_mass, 6, nonneg=True))
        object.__setattr__(
            self, "linear_damping", _vec("linear_damping", self.linear_damping, 6, nonneg=True)
        )
        object.__setattr__(
            self,
            "quadratic_damping",
            _vec("quadratic_damping", self.quadratic_damping, 6, nonneg=True),
        )

    @property
    def rigid_body_mass(self) -> np.ndarray:
        """diag(M_RB) (6,)."""
        return np.concatenate([[self.mass] * 3, self.inertia])


class HydroBatch:
    """The model above for N vehicles at once, in one compiled pass per physics step.

    Holds the stacked parameters (``packed``, the (N, 37) layout of ``sim.physics_kernel``)
    and the last body acceleration ν̇* (``last_accel``). ``sim.world`` steps through
    ``sim.physics_kernel.step_world`` (forces computed between ``mj_step1`` and
    ``mj_step2`` without returning to Python); ``body_wrench`` is the same evaluation for
    stacked numpy states, for a single forward pass and for tests. The previous numpy
    implementations live on as the test reference (tests/helpers/hydro_reference.py).
    """

    def __init__(self, params: list[HydroParams], rho: float, gravity: float, surface_z: float):
        if not params:
            raise ValueError("HydroBatch needs at least one vehicle")
        self.n = len(params)
        self.rho = float(rho)
        self.g = float(gravity)
        self.surface_z = float(surface_z)
        p = params
        mrb = np.stack([q.rigid_body_mass for q in p])  # (N, 6)
        ma = np.stack([q.added_mass for q in p])  # (N, 6)
        h = np.array([q.height for q in p])
        mass = np.array([q.mass for q in p])
        self.packed = np.ascontiguousarray(
            np.column_stack(
                [
                    mrb,
                    ma,
                    1.0 / (mrb + ma),  # diagonal total mass -> element-wise inverse
                    np.stack([q.linear_damping for q in p]),
                    np.stack([q.quadratic_damping for q in p]),
                    np.stack([q.r_cb for q in p]),
                    mass * self.g,  # weight W
                    self.rho * np.array([q.volume for q in p]) * self.g,  # buoyancy, submerged
                    1.0 / h,
                    0.5 + self.surface_z / h,  # submerged fraction = offset − z / height
                ]
            )
        )
        self.last_accel = np.zeros((self.n, 6))

    def body_wrench(
        self,
        rot: np.ndarray,
        pos: np.ndarray,
        vel_world: np.ndarray,
        omega_body: np.ndarray,
        current_world: np.ndarray | None,
        tau: np.ndarray,
        thrusters=None,
    ) -> np.ndarray:
        """xfrc_applied rows (N, 6) for states rot (N,3,3) body->world, pos (N,3) CG world m,
        vel_world (N,3) m/s, omega_body (N,3) rad/s, current_world (N,3) m/s or None, and
        tau (N,6) body-frame external wrench. ``thrusters`` (a ``sim.thrusters.ThrusterBank``
        or None) is advanced one step with this step's relative velocity ν_r and its wrench
        added to tau. Stores ν̇* in ``last_accel``."""
        n = self.n
        f64 = np.float64

        def arr(a, shape):
            # always a writable C array: numba compiles one specialisation per
            # read-only/writable combination, and broadcast_to views are read-only
            a = np.asarray(a, dtype=f64)
            if a.shape == shape and a.flags.c_contiguous and a.flags.writeable:
                return a
            return np.array(np.broadcast_to(a, shape), order="C")

        cur = np.zeros((n, 3)) if current_world is None else arr(current_world, (n, 3))
        if thrusters is None:
            table, offsets, state = np.zeros((0, 10)), np.zeros(n + 1, np.intp), np.zeros((4, 0))
        else:
            table, offsets, state = thrusters.table, thrusters.offsets, thrusters.state
        out = np.empty((n, 6))
        acc = np.empty((n, 6))
        wrench_batch(
            arr(rot, (n, 3, 3)), arr(pos, (n, 3)), arr(vel_world, (n, 3)),
            arr(omega_body, (n, 3)), cur, arr(tau, (n, 6)), self.packed, table, offsets,
            state, out, acc,
        )  # fmt: skip
        self.last_accel = acc
        return out

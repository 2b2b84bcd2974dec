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


_EPS = np.zeros((3, 3, 3))
_EPS[0, 1, 2] = _EPS[1, 2, 0] = _EPS[2, 0, 1] = 1.0
_EPS[0, 2, 1] = _EPS[2, 1, 0] = _EPS[1, 0, 2] = -1.0
# offsets in z = [v_r, ω, v, s·e_z, e_z, 1]
_VR, _W, _V, _EB, _EZ, _ONE = 0, 3, 6, 9, 12, 15


def _quadratic_tensor(h: HydroParams, rho: float, g: float) -> np.ndarray:
    """Q (256, 12) with out_i = Σ_jk Q[16 j + k, i] z_j z_k (see ``HydroBatch.body_wrench``).

    Outputs 0–5: the right-hand side terms besides τ and damping,
        lin: −ω×(A_v v_r) − ω×(m v) − A_v(ω×v) + A_v(ω×v_r) − W e_z + B s e_z
        ang: −v_r×(A_v v_r) − ω×(A_ω ω) − ω×(I ω) + B r_B×(s e_z)
    Outputs 6–11: the extra applied-force terms C_RB(ν)ν − f_gravity,
        lin: ω×(m v) + W e_z;  ang: ω×(I ω).
    """
    Q = np.zeros((16, 16, 12))
    av = np.asarray(h.added_mass[:3])
    aw = np.asarray(h.added_mass[3:])
    inertia = np.asarray(h.inertia)
    m = float(h.mass)
    one = np.ones(3)
    W = m * g
    B = rho * h.volume * g

    def cross(ia: int, ib: int, out: int, coef, d) -> None:
        # out_i += coef_i · (a × (d ∘ b))_i = coef_i ε_ilm a_l d_m b_m
        Q[ia : ia + 3, ib : ib + 3, out : out + 3] += np.einsum(
            "ilm,i,m->lmi", _EPS, np.broadcast_to(coef, 3), np.broadcast_to(d, 3)
        )

    cross(_W, _VR, 0, -1.0, av)
    cross(_W, _V, 0, -1.0, m * one)
    cross(_W, _V, 0, -av, one)
    cross(_W, _VR, 0, av, one)
    for i in range(3):
        Q[_EZ + i, _ONE, 0 + i] += -W
        Q[_EB + i, _ONE, 0 + i] += B
    cross(_VR, _VR, 3, -1.0, av)
    cross(_W, _W, 3, -1.0, aw)
    cross(_W, _W, 3, -1.0, inertia)
    # B r_B × e_b: (r × e)_i = ε_ilm r_l e_m, linear in e_b (paired with the constant 1)
    Q[_EB : _EB + 3, _ONE, 3:6] += B * np.einsum("ilm,l->mi", _EPS, np.asarray(h.r_cb))
    cross(_W, _V, 6, 1.0, m * one)
    for i in range(3):
        Q[_EZ + i, _ONE, 6 + i] += W
    cross(_W, _W, 9, 1.0, inertia)
    return Q.reshape(256, 12)


class HydroBatch:
    """The model above for N vehicles at once: one numpy pass per physics step.

    ``body_wrench`` takes stacked states and returns the world-frame ``xfrc_applied``
    rows (N, 6) [force; torque] that make MuJoCo integrate the full model, evaluating all
    quadratic terms of all vehicles with one outer product and one batched matrix product
    (per-step cost is set by the number of numpy calls, ≈ 30, not by N).
    ``body_wrench_explicit`` is the same model written term by term (the reference the
    fast path is tested against).
    """

    def __init__(self, params: list[HydroParams], rho: float, gravity: float, surface_z: float):
        if not params:
            raise ValueError("HydroBatch needs at least one vehicle")
        self.n = len(params)
        self.rho = float(rho)
        self.g = float(gravity)
        self.surface_z = float(surface_z)
        p = params
        self.m = np.array([q.mass for q in p])[:, None]  # (N, 1)
        self.mrb = np.stack([q.rigid_body_mass for q in p])  # (N, 6)
        self.inertia = self.mrb[:, 3:].copy()
        self.ma = np.stack([q.added_mass for q in p])  # (N, 6)
        self.ma_lin = self.ma[:, :3].copy()
        self.ma_rot = self.ma[:, 3:].copy()
        self.dl = np.stack([q.linear_damping for q in p])
        self.dq = np.stack([q.quadratic_damping for q in p])
        self.r_cb = np.stack([q.r_cb for q in p])
        self.weight = self.m[:, 0] * self.g  # (N,)
        self.neg_weight = -self.weight[:, None]
        self.buoyancy = self.rho * np.array([q.volume for q in p]) * self.g  # fully submerged
        h = np.array([q.height for q in p])
        self.inv_h = 1.0 / h
        self.sub_offset = 0.5 + self.surface_z / h
        self.minv = 1.0 / (self.mrb + self.ma)  # diagonal total mass -> element-wise inverse
        self.last_accel = np.zeros((self.n, 6))
        self._a = np.zeros((self.n, 7, 5))
        self._b = np.zeros((self.n, 7, 5))
        self._a[:, 5, :3] = self.r_cb
        self._q = np.stack([_quadratic_tensor(q, self.rho, self.g) for q in p])  # (N, 256, 12)
        self._z = np.zeros((self.n, 16))
        self._z[:, 15] = 1.0

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
        """xfrc_applied rows (N, 6); same arguments, result and side effects as
        ``body_wrench_explicit`` (the readable reference it is tested against).

        Every term of the model except damping and τ is a polynomial of degree ≤ 2 in
        z = [v_r, ω, v, s·e_z, e_z, 1] (16,) — Coriolis and added-mass Coriolis terms are
        bilinear, M_A ν̇_c = −A_v (ω × (v − v_r)) too, weight and buoyancy (with the
        submerged fraction s and e_z the world vertical in body axes) are linear. Each
        vehicle's coefficients sit in a constant tensor Q (256, 12) built once
        (``_quadratic_tensor``), so a step evaluates all of them for all vehicles with
        one outer product and one batched matrix product:
        [rhs terms (6) | applied-force terms (6)] = (z ⊗ z) Q.
        """
        ez = rot[:, 2, :]  # world z axis in body coordinates
        z = self._z
        if current_world is None:
            v = (vel_world[:, None, :] @ rot)[:, 0, :]  # R^T v
            z[:, 0:3] = v
        else:
            vv = np.stack([vel_world, current_world], axis=1) @ rot
            v = vv[:, 0, :]
            z[:, 0:3] = v - vv[:, 1, :]
        z[:, 3:6] = omega_body
        z[:, 6:9] = v
        z[:, 12:15] = ez
        sub = np.minimum(np.maximum(self.sub_offset - pos[:, 2] * self.inv_h, 0.0), 1.0)
        z[:, 9:12] = sub[:, None] * ez
        q = ((z[:, :, None] * z[:, None, :]).reshape(self.n, 1, 256) @ self._q)[:, 0, :]
        nur = z[:, :6]
        if thrusters is not None:
            tau = tau + thrusters.step(nur)
        acc = (tau + q[:, :6] - (self.dl + self.dq * np.abs(nur)) * nur) * self.minv
        self.last_accel = acc
        f = self.mrb * acc + q[:, 6:]
        return (f.reshape(-1, 2, 3) @ np.swapaxes(rot, 1, 2)).reshape(-1, 6)

    def body_wrench_explicit(
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
        added to tau. Stores ν̇* in ``last_accel``.

        Written for few numpy calls (each costs ~1 µs whatever N is): the cross products
        of a step go through one batched evaluation on buffers whose last axis repeats
        the first two components ([x, y, z, x, y]), so a×b = a[1:4]·b[2:5] − a[2:5]·b[1:4]
        uses views only."""
        w = omega_body
        ez = rot[:, 2, :]  # world z axis in body coordinates (row 3 of body->world)
        if current_world is None:
            v = (vel_world[:, None, :] @ rot)[:, 0, :]  # R^T v
            vr = v
        else:
            vv = np.stack([vel_world, current_world], axis=1) @ rot
            v = vv[:, 0, :]
            vc = vv[:, 1, :]
            vr = v - vc
        nur = np.concatenate([vr, w], axis=1)
        if thrusters is not None:
            tau = tau + thrusters.step(nur)
        damp = (self.dl + self.dq * np.abs(nur)) * nur
        # buoyancy along +z_world scaled by the submerged fraction of the height
        sub = np.minimum(np.maximum(self.sub_offset - pos[:, 2] * self.inv_h, 0.0), 1.0)
        fb = (self.buoyancy * sub)[:, None] * ez
        fw = self.neg_weight * ez
        # cross products: 0 w×(A v_r), 1 w×(m v), 2 v_r×(A v_r), 3 w×(A_ω ω), 4 w×(I ω),
        # 5 r_B×f_B, 6 w×v_c
        a = self._a
        b = self._b
        a[:, 0, :3] = w
        a[:, 1, :3] = w
        a[:, 2, :3] = vr
        a[:, 3, :3] = w
        a[:, 4, :3] = w
        a[:, 6, :3] = w
        b[:, 0, :3] = self.ma_lin * vr
        b[:, 1, :3] = self.m * v
        b[:, 2, :3] = b[:, 0, :3]
        b[:, 3, :3] = self.ma_rot * w
        b[:, 4, :3] = self.inertia * w
        b[:, 5, :3] = fb
        if current_world is not None:
            b[:, 6, :3] = vc
        a[:, :, 3:] = a[:, :, :2]
        b[:, :, 3:] = b[:, :, :2]
        c = a[:, :, 1:4] * b[:, :, 2:5] - a[:, :, 2:5] * b[:, :, 1:4]
        rhs = tau - damp
        rhs[:, :3] += fw + fb - c[:, 0] - c[:, 1]
        rhs[:, 3:] += c[:, 5] - c[:, 2] - c[:, 3] - c[:, 4]
        if current_world is not None:
            rhs[:, :3] -= self.ma_lin * c[:, 6]  # + M_A ν̇_c with ν̇_c = −ω × v_c
        acc = rhs * self.minv
        self.last_accel = acc
        # force that makes MuJoCo's rigid body (with its own gravity) produce `acc`:
        # f = M_RB acc + C_RB(ν) ν − f_gravity; C_RB ν = [w×(m v); w×(I w)]
        f = self.mrb * acc
        f[:, :3] += c[:, 1] - fw
        f[:, 3:] += c[:, 4]
        return (f.reshape(-1, 2, 3) @ np.swapaxes(rot, 1, 2)).reshape(-1, 6)

"""The numpy hydrodynamics that undersea used before the compiled step
(sim.physics_kernel): kept here, unchanged, as the reference the compiled model is
tested against (tests/sim/test_hydrodynamics_kernel.py).

``ReferenceHydroBatch.body_wrench`` is the quadratic-form evaluation (z ⊗ z) Q and
``body_wrench_explicit`` the term-by-term one; ``reference_step`` advances a world as
``World.step`` did (mj_step1 → numpy forces and numpy ``ThrusterBank.step`` → mj_step2).
"""

from __future__ import annotations

import mujoco
import numpy as np

from sim.hydrodynamics import HydroParams

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


class ReferenceHydroBatch:
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


def reference_step(world, ref: ReferenceHydroBatch, n: int) -> None:
    """n steps of ``world`` with the forces of ``ref`` (the pre-kernel World.step)."""
    m, d = world.model, world.data
    bid = world._body_ids
    dofs = world._dof0[:, None] + np.arange(6)[None, :]
    for _ in range(int(n)):
        mujoco.mj_step1(m, d)
        qv = d.qvel[dofs]
        cur = None if world.current.is_zero else world.current.velocity(d.xpos[bid], d.time)
        d.xfrc_applied[bid] = ref.body_wrench(
            d.xmat[bid].reshape(-1, 3, 3),
            d.xpos[bid],
            qv[:, :3],
            qv[:, 3:],
            cur,
            world._external,
            world.thrusters,
        )
        mujoco.mj_step2(m, d)


def random_hydro_params(rng, n: int) -> list[HydroParams]:
    """``n`` random but physical vehicles (masses 5-200 kg, volumes 5-200 l, ...), the
    draws shared by the hydrodynamics property tests (same draws, same order)."""
    return [
        HydroParams(
            mass=rng.uniform(5, 200),
            inertia=rng.uniform(0.1, 50, 3),
            volume=rng.uniform(0.005, 0.2),
            r_cb=rng.normal(0, 0.03, 3),
            added_mass=rng.uniform(0, 100, 6),
            linear_damping=rng.uniform(0, 50, 6),
            quadratic_damping=rng.uniform(0, 50, 6),
            height=rng.uniform(0.2, 1.0),
        )
        for _ in range(n)
    ]

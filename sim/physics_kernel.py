"""Compiled physics step: the Fossen model of ``sim.hydrodynamics`` and the thruster bank of
``sim.thrusters`` for every vehicle, evaluated inside MuJoCo's own step loop.

One call of ``step_world`` runs n physics steps without returning to Python:

    for each step:  mj_step1(m, d)  →  currents, thrusters, hydrodynamics of all vehicles
                    (one pass over N vehicles, written into d.xfrc_applied)  →  mj_step2(m, d)

``mj_step1`` / ``mj_step2`` are MuJoCo's C functions, called through their addresses in the
library the ``mujoco`` bindings loaded (``_call_mj``), so the per-step cost is MuJoCo's step
plus ≈ 0.1 µs of arithmetic per vehicle: no numpy call, no Python object per step. The
functions are compiled by numba on first use and cached on disk (``cache=True``).

The terms are exactly those of ``sim.hydrodynamics`` (weight and buoyancy with partial
submergence, added mass solved with the rigid body, C_RB and C_A Coriolis, linear +
quadratic damping on the velocity relative to the water, M_A ν̇_c of the current) and
``sim.thrusters.ThrusterBank.step`` (first-order lag, quadratic propeller curve, fin lift
with stall-limited incidence); the numbers agree with the numpy implementations to
rounding (tests/sim/test_hydrodynamics_kernel.py, 1e-9). The current field of
``sim.world.currents`` is evaluated in the loop at the step's start time, accumulated as
MuJoCo accumulates ``d.time`` (t ← t + h), so it sees the same times.

Packed arrays (built once by ``HydroBatch`` / ``ThrusterBank`` / ``CurrentField``):
  P  (N, 37) per vehicle: diag M_RB 0:6 | M_A 6:12 | 1/(M_RB + M_A) 12:18 | D_l 18:24 |
     D_q 24:30 | r_B 30:33 | W 33 | B 34 | 1/height 35 | submergence offset 36.
  T  (k, 10) per channel: configuration column 0:6 | F_fwd 6 | F_rev 7 | ½ρSC_Lα 8 | fin 9.
  C  (K, 5) per current mode: k_x, k_y, ω, φ, amplitude; ``cu`` (3,) the uniform current.
"""

from __future__ import annotations

import ctypes
import glob
import os

import mujoco
import numba
import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from sim.thrusters import FIN_STALL_RAD

P_COLS = 37
T_COLS = 10


def _mujoco_library() -> ctypes.CDLL:
    """The MuJoCo shared library the Python bindings loaded (dlopen of a loaded path
    returns the same handle, so the addresses are those the bindings call)."""
    here = os.path.dirname(mujoco.__file__)
    found = sorted(
        glob.glob(os.path.join(here, "libmujoco.so*"))
        + glob.glob(os.path.join(here, "libmujoco*.dylib"))
        + glob.glob(os.path.join(here, "mujoco.dll"))
    )
    if not found:
        raise ImportError(f"MuJoCo shared library not found beside the bindings in {here}")
    return ctypes.CDLL(found[0])


_LIB = _mujoco_library()
MJ_STEP1 = ctypes.cast(_LIB.mj_step1, ctypes.c_void_p).value
MJ_STEP2 = ctypes.cast(_LIB.mj_step2, ctypes.c_void_p).value


@intrinsic
def _call_mj(typingctx, fn, m, d):
    """Call the C function ``void fn(const mjModel*, mjData*)`` at address fn (all intp)."""
    sig = types.void(types.intp, types.intp, types.intp)

    def codegen(context, builder, signature, args):
        vp = ir.IntType(8).as_pointer()
        fnty = ir.FunctionType(ir.VoidType(), [vp, vp])
        f = builder.inttoptr(args[0], fnty.as_pointer())
        builder.call(f, [builder.inttoptr(args[1], vp), builder.inttoptr(args[2], vp)])
        return context.get_dummy_value()

    return sig, codegen


@numba.njit(cache=True, inline="always")
def _cross(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@numba.njit(cache=True)
def _current(pos, t, cu, C, out):
    """World-frame current (3,) at pos (3,) and time t into out (sim.world.currents)."""
    u = cu[0]
    v = cu[1]
    for k in range(C.shape[0]):
        c = np.cos(pos[0] * C[k, 0] + pos[1] * C[k, 1] - C[k, 2] * t + C[k, 3]) * C[k, 4]
        u += c * C[k, 1]  # u = ∂ψ/∂y
        v -= c * C[k, 0]  # v = −∂ψ/∂x
    out[0] = u
    out[1] = v
    out[2] = cu[2]


@numba.njit(cache=True)
def _vehicle(R, pos, vw, w, cur, tau, p, T, lo, hi, S, f_out, acc, work):
    """One vehicle: body->world R (3,3), CG pos (3,), world velocity vw (3,), body angular
    velocity w (3,), world current cur (3,), external body wrench tau (6,), parameters p
    (37,), its thruster channels T[lo:hi] with their state S (4, k) rows command, level,
    force, decay (``ThrusterBank.state``). Advances the lag (level, force in place);
    writes the world-frame xfrc_applied row f_out (6,) and ν̇* into acc (6,). work (5, 6)
    is scratch memory (no allocation per call: an allocation costs more than the
    arithmetic)."""
    v = work[0]
    vr = work[1]
    ez = work[2]
    for j in range(3):
        v[j] = R[0, j] * vw[0] + R[1, j] * vw[1] + R[2, j] * vw[2]
        vc_j = R[0, j] * cur[0] + R[1, j] * cur[1] + R[2, j] * cur[2]
        vr[j] = v[j] - vc_j
        ez[j] = R[2, j]
    nur = (vr[0], vr[1], vr[2], w[0], w[1], w[2])
    # thrusters (sim.thrusters.ThrusterBank.step)
    tt = work[3]
    tt[:] = 0.0
    au = abs(vr[0])
    for ch in range(lo, hi):
        c = S[0, ch]
        lv = c + (S[1, ch] - c) * S[3, ch]
        S[1, ch] = lv
        if T[ch, 9] != 0.0:
            lim = FIN_STALL_RAD * au
            fc = 0.0
            for j in range(6):
                fc += T[ch, j] * nur[j]
            fc = min(max(fc, -lim), lim)
            fch = au * (T[ch, 6] * lv * vr[0] - T[ch, 8] * fc)
        else:
            fch = lv * abs(lv) * (T[ch, 6] if lv >= 0.0 else T[ch, 7])
        S[2, ch] = fch
        for j in range(6):
            tt[j] += T[ch, j] * fch
    # gravity and buoyancy (buoyancy scaled by the submerged fraction of the height)
    sub = min(max(p[36] - pos[2] * p[35], 0.0), 1.0)
    fb = p[34] * sub
    W = p[33]
    m = p[0]
    avr = (p[6] * vr[0], p[7] * vr[1], p[8] * vr[2])
    c0 = _cross(w[0], w[1], w[2], avr[0], avr[1], avr[2])  # ω × (A_v v_r)
    c1 = _cross(w[0], w[1], w[2], m * v[0], m * v[1], m * v[2])  # ω × (m v)
    c2 = _cross(vr[0], vr[1], vr[2], avr[0], avr[1], avr[2])  # v_r × (A_v v_r)
    c3 = _cross(w[0], w[1], w[2], p[9] * w[0], p[10] * w[1], p[11] * w[2])  # ω × (A_ω ω)
    c4 = _cross(w[0], w[1], w[2], p[3] * w[0], p[4] * w[1], p[5] * w[2])  # ω × (I ω)
    c5 = _cross(p[30], p[31], p[32], fb * ez[0], fb * ez[1], fb * ez[2])  # r_B × f_B
    c6 = _cross(w[0], w[1], w[2], v[0] - vr[0], v[1] - vr[1], v[2] - vr[2])  # ω × v_c
    f = work[4]
    for j in range(3):
        damp = (p[18 + j] + p[24 + j] * abs(nur[j])) * nur[j]
        rhs = tau[j] + tt[j] - damp + (fb - W) * ez[j] - c0[j] - c1[j] - p[6 + j] * c6[j]
        a = rhs * p[12 + j]
        acc[j] = a
        # f = M_RB ν̇* + C_RB(ν) ν − f_gravity makes MuJoCo's rigid body produce ν̇*
        f[j] = p[j] * a + c1[j] + W * ez[j]
        k = 3 + j
        damp = (p[18 + k] + p[24 + k] * abs(nur[k])) * nur[k]
        rhs = tau[k] + tt[k] - damp + c5[j] - c2[j] - c3[j] - c4[j]
        a = rhs * p[12 + k]
        acc[k] = a
        f[k] = p[k] * a + c4[j]
    for j in range(3):
        f_out[j] = R[j, 0] * f[0] + R[j, 1] * f[1] + R[j, 2] * f[2]
        f_out[3 + j] = R[j, 0] * f[3] + R[j, 1] * f[4] + R[j, 2] * f[5]


@numba.njit(cache=True)
def wrench_batch(rot, pos, vel, omega, cur, tau, P, T, offsets, S, out, acc):
    """``_vehicle`` for stacked states: rot (N,3,3), pos/vel/omega/cur (N,3), tau (N,6);
    out, acc (N,6) written. The numpy-facing entry (``HydroBatch.body_wrench``)."""
    work = np.empty((5, 6))
    for i in range(P.shape[0]):
        _vehicle(
            rot[i], pos[i], vel[i], omega[i], cur[i], tau[i], P[i], T,
            offsets[i], offsets[i + 1], S, out[i], acc[i], work,
        )  # fmt: skip


@numba.njit(cache=True)
def step_world(addr, n, t0, dt, xmat, xpos, qvel, xfrc, ids, tau, P, T, offsets, S, cu, C, acc):
    """n MuJoCo steps with the forces of all N vehicles applied between mj_step1 and
    mj_step2. addr (4,) int: the addresses of mj_step1 and mj_step2 (``MJ_STEP1``,
    ``MJ_STEP2``; arguments, not globals, so that the disk cache holds no address), of the
    mjModel and of the mjData. xmat (nbody,9), xpos (nbody,3), qvel (nv,), xfrc (nbody,6)
    are that MjData's arrays (views); ids (2, N) the vehicles' root bodies and first dofs
    of their free joints; t0 = d.time, dt the model timestep; the current varies when C
    has rows. Returns the time after the steps as MuJoCo accumulates it, or NaN when a
    velocity is not finite at the end."""
    cur = np.zeros(3)
    work = np.empty((5, 6))
    t = t0
    varying = C.shape[0] > 0
    for _ in range(n):
        _call_mj(addr[0], addr[2], addr[3])
        for i in range(ids.shape[1]):
            b = ids[0, i]
            q = ids[1, i]
            if varying:
                _current(xpos[b], t, cu, C, cur)
            else:
                cur[0] = cu[0]
                cur[1] = cu[1]
                cur[2] = cu[2]
            _vehicle(
                xmat[b].reshape(3, 3), xpos[b], qvel[q : q + 3], qvel[q + 3 : q + 6], cur,
                tau[i], P[i], T, offsets[i], offsets[i + 1], S, xfrc[b], acc[i], work,
            )  # fmt: skip
        _call_mj(addr[1], addr[2], addr[3])
        t += dt
    for j in range(qvel.shape[0]):
        if not np.isfinite(qvel[j]):
            return np.nan
    return t

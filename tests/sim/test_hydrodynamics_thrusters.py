"""Thruster model and allocation: first-order lag (exact exponential), quadratic thrust
curve, saturation, and the allocation reproducing the demanded wrench (B f = τ)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sim.thrusters import ThrusterBank, ThrusterSpec
from sim.world import SeabedSpec, VehicleSpec, WorldSpec, build_world

SMALL = SeabedSpec(kind="flat", size_xy=(100.0, 100.0), resolution=4.0, depth=60.0)


def _bank(dt=0.01):
    specs = [
        ThrusterSpec("a", "propeller", 40.0, 20.0, 0.2, (-1.0, 0.1, 0.0), (1.0, 0.0, 0.0)),
        ThrusterSpec("b", "propeller", 30.0, 30.0, 0.1, (0.5, 0.0, 0.0), (0.0, 0.0, 1.0)),
    ]
    return ThrusterBank([specs], dt)


def test_lag_follows_first_order_step_response_and_quadratic_curve():
    """n(t) = 1 − e^(−t/T) for a unit step; F = F_max n|n|."""
    b = _bank()
    b.set_commands(0, [1.0, -0.5])
    for k in range(1, 41):
        b.step(None)
        t = 0.01 * k
        n_a = 1 - np.exp(-t / 0.2)
        n_b = -0.5 * (1 - np.exp(-t / 0.1))
        np.testing.assert_allclose(b.level, [n_a, n_b], rtol=1e-12)
        np.testing.assert_allclose(b.force, [40.0 * n_a * n_a, -30.0 * n_b * n_b], rtol=1e-12)


def test_commands_saturate_at_unit_magnitude():
    b = _bank()
    b.set_commands(0, [3.0, -7.0])
    np.testing.assert_array_equal(b.command, [1.0, -1.0])


@pytest.mark.parametrize("bad", [[1.0], [np.nan, 0.0], [0.0, 0.0, 0.0]])
def test_bad_commands_raise(bad):
    with pytest.raises(ValueError, match="thruster commands"):
        _bank().set_commands(0, bad)


@pytest.mark.parametrize("kind", ["ixn", "naiad", "saga", "rexrov"])
@settings(max_examples=15, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_allocation_reproduces_feasible_wrench_on_controlled_dofs(kind, seed):
    """τ in the span of the configuration matrix and inside saturation → steady-state thrust
    wrench equals τ on the controlled DOFs (second computation: B · F(u))."""
    w = build_world(WorldSpec(seabed=SMALL, vehicles=(VehicleSpec(kind, position=(0, 0, -20)),)))
    v = w.vehicles[kind]
    bank = w.thrusters
    rng = np.random.default_rng(seed)
    lo, hi = bank.offsets[0], bank.offsets[1]
    cols = bank.columns[lo:hi].T
    # a random achievable wrench: forces at 30 % of the weaker direction's maximum
    f = rng.uniform(-0.3, 0.3, hi - lo) * np.minimum(bank.f_fwd[lo:hi], bank.f_rev[lo:hi])
    tau = cols @ f
    mask = v.model.dof_mask
    tau[~mask] = 0.0
    v.apply_wrench_demand(tau)
    u = bank.command[lo:hi]
    fu = np.where(u >= 0, bank.f_fwd[lo:hi], bank.f_rev[lo:hi]) * u * np.abs(u)
    np.testing.assert_allclose((cols @ fu)[mask], tau[mask], atol=1e-6 * (1 + np.abs(tau).max()))


def test_torpedo_fins_allocate_yaw_with_speed_squared_gain():
    """Fin force ∝ u_r²: the same yaw demand needs 4× less deflection at twice the speed."""
    w = build_world(
        WorldSpec(seabed=SMALL, vehicles=(VehicleSpec("alister9", position=(0, 0, -20)),))
    )
    v = w.vehicles["alister9"]
    defl = []
    for speed in (1.0, 2.0):
        v.set_pose((0, 0, -20), velocity_body=(speed, 0, 0))
        v.apply_wrench_demand([0, 0, 0, 0, 0, 0.5])
        defl.append(w.thrusters.command[1])
    assert defl[0] != 0.0
    assert defl[0] / defl[1] == pytest.approx(4.0, rel=1e-6)


def test_tau_with_nan_is_rejected():
    w = build_world(WorldSpec(seabed=SMALL, vehicles=("saga",)))
    with pytest.raises(ValueError, match="tau"):
        w.vehicles["saga"].apply_wrench_demand([0, 0, np.nan, 0, 0, 0])


def test_saturated_allocation_redistributes_to_free_thrusters():
    """Redistributed pseudo-inverse: a yaw + surge demand beyond one channel's limit keeps
    every command in [−1, 1] and still delivers more of the demand than plain clipping
    of the unconstrained solution (second computation: B·F(u) for both)."""
    w = build_world(WorldSpec(seabed=SMALL, vehicles=(VehicleSpec("naiad", position=(0, 0, -20)),)))
    v = w.vehicles["naiad"]
    bank = w.thrusters
    cols = bank.columns.T
    mask = v.model.dof_mask
    tau = np.array([120.0, 0.0, 0.0, 0.0, 0.0, 15.0])
    v.apply_wrench_demand(tau)
    u = bank.command.copy()
    assert np.all(np.abs(u) <= 1.0)

    def wrench(cmd):
        return cols @ (np.where(cmd >= 0, bank.f_fwd, bank.f_rev) * cmd * np.abs(cmd))

    f_ls = np.linalg.pinv(cols[mask]) @ tau[mask]
    u_clip = np.clip(
        np.sign(f_ls) * np.sqrt(np.abs(f_ls) / np.where(f_ls >= 0, bank.f_fwd, bank.f_rev)), -1, 1
    )
    err_redist = np.linalg.norm((wrench(u) - tau)[mask])
    err_clip = np.linalg.norm((wrench(u_clip) - tau)[mask])
    assert err_redist < err_clip


def test_fin_incidence_lift_opposes_cross_flow_and_saturates_at_stall():
    """Passive fin lift F = −½ρSC_Lα |u| w_f (opposes the flow across the fin) for small
    incidence, and is capped at ½ρSC_Lα u² α_stall beyond the stall angle."""
    from sim.thrusters import FIN_STALL_RAD

    gain = 40.0
    spec = ThrusterSpec(
        "rudder", "fin", gain * 0.35, gain * 0.35, 0.1, (-0.85, 0, 0), (0, 1, 0), lift_gain=gain
    )
    b = ThrusterBank([[spec]], 0.01)
    u = 2.0
    small = np.array([[u, 0.05, 0, 0, 0, 0]])  # sway 0.05 m/s: α = 0.025 rad
    b.step(small)
    assert b.force[0] == pytest.approx(-gain * u * 0.05)
    big = np.array([[u, 3.0, 0, 0, 0, 0]])  # α = 56°
    b.step(big)
    assert b.force[0] == pytest.approx(-gain * u * u * FIN_STALL_RAD)
    # yaw rate r swings the tail (x = −0.85) to starboard: flow across the fin is −0.85 r
    b.step(np.array([[u, 0, 0, 0, 0, 0.1]]))
    assert b.force[0] == pytest.approx(gain * u * 0.085)


def _allocate_dense(bank, vehicle, tau, dofs, speed_sq):
    """The allocation as formulated before the pseudo-inverse cache: np.linalg.pinv of
    the fin-scaled matrix on every pass (the reference of the cached allocation)."""
    lo, hi = bank.offsets[vehicle], bank.offsets[vehicle + 1]
    cols = bank.columns[lo:hi].T.copy()
    fin = bank.is_fin[lo:hi]
    cols[:, fin] *= speed_sq
    b, t, k = cols[dofs], np.asarray(tau, dtype=float)[dofs], hi - lo
    upper, lower = bank.f_fwd[lo:hi].copy(), -bank.f_rev[lo:hi]
    f, free = np.zeros(k), np.ones(k, dtype=bool)
    for it in range(k):
        if it == 0:
            f = np.linalg.pinv(b, rcond=1e-6) @ t
        else:
            resid = t - b[:, ~free] @ f[~free]
            f[free] = np.linalg.pinv(b[:, free], rcond=1e-6) @ resid
        over = free & ((f > upper) | (f < lower))
        if not over.any():
            break
        f[over] = np.clip(f[over], lower[over], upper[over])
        free &= ~over
        if not free.any():
            break
    return f


def _forces(bank, vehicle, u, speed_sq):
    """Channel forces of commands u (the inverse of allocate's inverse thrust curve)."""
    lo, hi = bank.offsets[vehicle], bank.offsets[vehicle + 1]
    fin = bank.is_fin[lo:hi]
    f_prop = np.where(u >= 0, bank.f_fwd[lo:hi], bank.f_rev[lo:hi]) * u * np.abs(u)
    return np.where(fin, u * bank.f_fwd[lo:hi], f_prop)


@pytest.mark.parametrize("layout", ["alister9", "overactuated"])
def test_cached_finned_allocation_matches_dense_pseudo_inverse(layout):
    """Finned vehicles: the allocation reuses pinv(B0) scaled by the fin speed factor
    (pinv(B0 D) = D⁻¹ pinv(B0) for full column rank) or falls back to pinv(B0 D); the
    commands match the dense per-call pseudo-inverse within 1e-12 over speeds from
    reversing to fast, including zero and near-zero speed (the rcond cutoff) and saturated
    demands. "overactuated" (4 channels over 3 dofs) takes the fallback on its first pass."""
    if layout == "alister9":
        w = build_world(
            WorldSpec(seabed=SMALL, vehicles=(VehicleSpec("alister9", position=(0, 0, -20)),))
        )
        bank, dofs = w.thrusters, w.vehicles["alister9"].model.dof_mask
    else:
        specs = [
            ThrusterSpec("p", "propeller", 40.0, 20.0, 0.2, (-1.0, 0.0, 0.0), (1.0, 0.0, 0.0)),
            ThrusterSpec("q", "propeller", 30.0, 30.0, 0.2, (-1.0, 0.3, 0.0), (1.0, 0.0, 0.0)),
            ThrusterSpec("r", "fin", 5.0, 5.0, 0.1, (-0.8, 0.0, 0.0), (0.0, 1.0, 0.0), 14.0),
            ThrusterSpec("e", "fin", 5.0, 5.0, 0.1, (-0.8, 0.0, 0.0), (0.0, 0.0, 1.0), 14.0),
        ]
        bank, dofs = ThrusterBank([specs], 0.05), np.array([1, 0, 0, 0, 1, 1], dtype=bool)
    rng = np.random.default_rng(7)
    speeds = np.concatenate([[0.0, 1e-12, -1e-9, 1e-5, -4.0], rng.uniform(-1.0, 6.0, 400)])
    n_sat = 0
    for speed_sq in speeds:
        tau = rng.normal(size=6) * [30.0, 0.0, 0.0, 0.0, 8.0, 8.0]
        u = bank.allocate(0, tau, dofs, float(speed_sq))
        f_ref = _allocate_dense(bank, 0, tau, dofs, float(speed_sq))
        lo, hi = bank.offsets[0], bank.offsets[1]
        cap = np.maximum(bank.f_fwd[lo:hi], bank.f_rev[lo:hi])
        np.testing.assert_allclose(
            _forces(bank, 0, u, speed_sq), np.clip(f_ref, -cap, cap), rtol=0, atol=1e-12 * cap.max()
        )
        n_sat += bool(np.any(np.abs(u) >= 1.0))
    assert 0 < n_sat < speeds.size  # both the free and the redistributed passes were run

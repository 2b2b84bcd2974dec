"""Hydrodynamics: each test states its independent expectation (closed-form formula,
analytic balance, or a second implementation)."""

from __future__ import annotations

import numpy as np
import pytest
from hydro_reference import random_hydro_params
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from sim.hydrodynamics import (
    HydroBatch,
    HydroParams,
    ellipsoid_added_mass,
    strip_theory_quadratic_damping,
)
from sim.world import SeabedSpec, VehicleSpec, WorldSpec, build_world
from sim.world.currents import CurrentSpec

RHO = 1025.0
SMALL_SEABED = SeabedSpec(kind="flat", size_xy=(400.0, 400.0), resolution=4.0, depth=60.0)
KINDS = ("alister9", "ixn", "naiad", "saga", "rexrov")


def _world(kind: str, **kw) -> object:
    vs = VehicleSpec(kind, position=(0.0, 0.0, -20.0), **kw.pop("vehicle", {}))
    return build_world(WorldSpec(seabed=SMALL_SEABED, vehicles=(vs,), **kw))


# ---------------------------------------------------------------- added mass formulas
def test_sphere_added_mass_is_half_displaced_mass_lamb():
    r = 0.3
    am = ellipsoid_added_mass(r, r, r, RHO)
    disp = RHO * 4 / 3 * np.pi * r**3
    np.testing.assert_allclose(am[:3], 0.5 * disp, rtol=1e-10)
    np.testing.assert_allclose(am[3:], 0.0, atol=1e-12)


@pytest.mark.parametrize("ratio", [2.0, 5.0, 9.09])
def test_prolate_spheroid_matches_lamb_closed_form_k_factors(ratio):
    """Lamb (1932), *Hydrodynamics*, ch. V: closed forms in the eccentricity e of a prolate spheroid."""
    b = 0.11
    a = ratio * b
    e = np.sqrt(1 - (b / a) ** 2)
    lg = np.log((1 + e) / (1 - e))
    alpha0 = 2 * (1 - e**2) / e**3 * (0.5 * lg - e)
    beta0 = 1 / e**2 - (1 - e**2) / (2 * e**3) * lg
    k1 = alpha0 / (2 - alpha0)
    k2 = beta0 / (2 - beta0)
    kr = e**4 * (beta0 - alpha0) / ((2 - e**2) * (2 * e**2 - (2 - e**2) * (beta0 - alpha0)))
    m = RHO * 4 / 3 * np.pi * a * b * b
    iy = m * (a**2 + b**2) / 5  # moment of inertia of the displaced fluid about y
    am = ellipsoid_added_mass(a, b, b, RHO)
    np.testing.assert_allclose(am[0], k1 * m, rtol=1e-9)
    np.testing.assert_allclose(am[1:3], k2 * m, rtol=1e-9)
    np.testing.assert_allclose(am[4:], kr * iy, rtol=1e-9)
    assert am[3] == 0.0


def test_strip_theory_damping_translational_terms_are_half_rho_cd_area():
    dq = strip_theory_quadratic_damping(2.0, 0.5, 0.3, np.array([0.3, 1.0, 1.2]), RHO, "box")
    np.testing.assert_allclose(dq[:3], 0.5 * RHO * np.array([0.3 * 0.15, 1.0 * 0.6, 1.2 * 1.0]))
    # yaw: ½ρ Cd_y H ∫|x|³dx over [-L/2, L/2] = ½ρ Cd_y H L⁴/32
    np.testing.assert_allclose(dq[5], 0.5 * RHO * 1.0 * 0.3 * 2.0**4 / 32)


@pytest.mark.parametrize("field,value", [("mass", -1.0), ("volume", 0.0), ("height", -0.2)])
def test_bad_hydro_params_raise_naming_the_field(field, value):
    kw = dict(
        mass=10.0,
        inertia=np.ones(3),
        volume=0.01,
        r_cb=np.zeros(3),
        added_mass=np.zeros(6),
        linear_damping=np.zeros(6),
        quadratic_damping=np.zeros(6),
        height=0.3,
    )
    kw[field] = value
    with pytest.raises(ValueError, match=field):
        HydroParams(**kw)


# ---------------------------------------------------------------- vectorization


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_batched_hydro_equals_one_vehicle_at_a_time(seed):
    """Second implementation: N separate single-vehicle batches give the same rows."""
    rng = np.random.default_rng(seed)
    n = 4
    params = random_hydro_params(rng, n)
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    from sim.frames import matrix_from_wxyz

    rot = matrix_from_wxyz(q)
    pos = rng.normal(0, 5, (n, 3)) - [0, 0, 10]
    vel = rng.normal(0, 1, (n, 3))
    om = rng.normal(0, 0.5, (n, 3))
    cur = rng.normal(0, 0.5, (n, 3))
    tau = rng.normal(0, 20, (n, 6))
    all_rows = HydroBatch(params, RHO, 9.81, 0.0).body_wrench(rot, pos, vel, om, cur, tau)
    for i in range(n):
        one = HydroBatch([params[i]], RHO, 9.81, 0.0).body_wrench(
            rot[i : i + 1],
            pos[i : i + 1],
            vel[i : i + 1],
            om[i : i + 1],
            cur[i : i + 1],
            tau[i : i + 1],
        )
        np.testing.assert_allclose(all_rows[i], one[0], rtol=1e-12, atol=1e-9)


# ---------------------------------------------------------------- dynamic responses
@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("axis", [0, 1, 2])
def test_step_force_acceleration_is_force_over_mass_plus_added_mass(kind, axis):
    """a = F / (m + m_A) (within 2 %) from rest, not F / m."""
    w = _world(kind)
    v = w.vehicles[kind]
    h = v.hydro
    f = 0.05 * h.mass * 9.81
    tau = np.zeros(6)
    tau[axis] = f
    v.set_external_wrench(tau)
    w._forward()
    a0 = v.state().acceleration_body[axis]
    expect = f / (h.mass + h.added_mass[axis])
    assert a0 == pytest.approx(expect, rel=0.02)
    # and the velocity after 0.05 s (damping still negligible) follows the same mass
    w.step(5)
    vel = v.state().velocity_body[axis]
    assert vel == pytest.approx(expect * 0.05, rel=0.02)
    if h.added_mass[axis] > 0.05 * h.mass:
        assert abs(a0 - f / h.mass) > 0.03 * f / h.mass  # the added mass is visible


@pytest.mark.parametrize("kind", KINDS)
def test_trimmed_vehicle_without_thrust_holds_depth_60s(kind):
    """Neutral buoyancy (B = W) and CB above CG: no vertical drift beyond 0.05 m in 60 s."""
    w = _world(kind)
    v = w.vehicles[kind]
    z0 = v.state().position[2]
    zs = []
    for _ in range(60):
        w.step(100)
        zs.append(v.state().position[2])
    assert np.max(np.abs(np.array(zs) - z0)) < 0.05


def _roll_reference(h: HydroParams, phi0: float, t_end: float) -> tuple[np.ndarray, np.ndarray]:
    """1-DOF roll ODE, a second implementation: (I+A) φ̈ = −K_p φ̇ − K_pp|φ̇|φ̇ − W·BG sin φ."""
    inertia = h.inertia[0] + h.added_mass[3]
    wbg = h.mass * 9.81 * h.r_cb[2]

    def f(t, y):
        phi, p = y
        return [
            p,
            (-h.linear_damping[3] * p - h.quadratic_damping[3] * abs(p) * p - wbg * np.sin(phi))
            / inertia,
        ]

    t = np.arange(0.0, t_end, 0.01)
    sol = solve_ivp(f, (0, t_end), [phi0, 0.0], t_eval=t, rtol=1e-9, atol=1e-12)
    return sol.t, sol.y[0]


def _zero_crossings(t: np.ndarray, x: np.ndarray) -> np.ndarray:
    i = np.flatnonzero(np.sign(x[:-1]) != np.sign(x[1:]))
    return t[i] - x[i] * (t[i + 1] - t[i]) / (x[i + 1] - x[i])


@pytest.mark.parametrize("kind", KINDS)
def test_roll_30deg_decays_with_righting_sign_and_period(kind):
    """Released at 30° roll: the righting moment W·BG·sin φ turns it back (sign), the
    amplitude decays, and the period matches (a) the 1-DOF ODE solved by scipy within 2 %
    and (b) the small-angle period 2π√((I_xx + A_44)/(W·BG)) within 6 % (finite amplitude
    and damping lengthen it)."""
    w = _world(kind)
    v = w.vehicles[kind]
    from sim.frames import wxyz_from_euler

    phi0 = np.deg2rad(30.0)
    v.set_pose((0.0, 0.0, -20.0), wxyz_from_euler(phi0, 0.0, 0.0))
    h = v.hydro
    t_small = 2 * np.pi * np.sqrt((h.inertia[0] + h.added_mass[3]) / (h.mass * 9.81 * h.r_cb[2]))
    t_end = 3.0 * t_small
    ts, phis = [], []
    for _ in range(int(t_end / w.timestep)):
        w.step(1)
        s = v.state()
        ts.append(s.t)
        phis.append(s.euler[0])
    ts = np.array(ts)
    phis = np.array(phis)
    # sign: the first motion is back towards upright
    assert phis[5] < phi0
    # decay: every later extreme is smaller than the release angle
    assert np.max(np.abs(phis[ts > 0.75 * t_small])) < phi0
    zc = _zero_crossings(ts, phis)
    period = 2 * np.mean(np.diff(zc[:4]))
    tr, pr = _roll_reference(h, phi0, t_end)
    ref_period = 2 * np.mean(np.diff(_zero_crossings(tr, pr)[:4]))
    assert period == pytest.approx(ref_period, rel=0.02)
    assert period == pytest.approx(t_small, rel=0.06)


def _surge_command(kind: str) -> np.ndarray:
    return {
        "alister9": np.array([1.0, 0.0, 0.0]),
        "ixn": np.array([1.0, 1.0, 0, 0, 0, 0, 0, 0]),  # stern pair; fins at 0
        "naiad": np.array([1.0, 1.0, 1.0, 1.0, 0, 0]),
        "saga": np.array([1.0, 1.0, 1.0, 1.0, 0]),
        "rexrov": np.array([1.0, 1.0, 1.0, 1.0, 0, 0, 0, 0]),
    }[kind]


@pytest.mark.parametrize("kind", KINDS)
def test_terminal_surge_speed_matches_damping_balance(kind):
    """Steady state T = X_u u + X_uu u² ⇒ u = (−X_u + √(X_u² + 4 X_uu T)) / (2 X_uu)."""
    w = _world(kind)
    v = w.vehicles[kind]
    u_cmd = _surge_command(kind)
    v.set_thruster_commands(u_cmd)
    w.step(4000)
    thrust_x = float((w.thrusters.force[:, None] * w.thrusters.columns)[:, 0].sum())
    h = v.hydro
    xu, xuu = h.linear_damping[0], h.quadratic_damping[0]
    u_expect = (-xu + np.sqrt(xu * xu + 4 * xuu * thrust_x)) / (2 * xuu)
    assert v.state().velocity_body[0] == pytest.approx(u_expect, rel=0.02)


@pytest.mark.parametrize("kind", ["ixn", "naiad", "saga", "rexrov"])
def test_unpowered_vehicle_drifts_at_the_current_speed(kind):
    """Relative velocity → 0 in steady state: ground velocity = current (0.5 m/s) within 2 %
    after 150 s from rest. (The torpedo's axial damping is so small that its spin-up takes
    minutes; it is covered by the equilibrium test below.)"""
    cur = (0.5 * np.cos(0.6), 0.5 * np.sin(0.6), 0.0)
    w = _world(kind, current=CurrentSpec(velocity=cur))
    v = w.vehicles[kind]
    w.step(15000)
    s = v.state()
    vw = s.velocity_world
    np.testing.assert_allclose(vw[:2], cur[:2], atol=0.01)
    assert np.linalg.norm(vw) == pytest.approx(0.5, rel=0.02)
    np.testing.assert_allclose(s.water_velocity_world, cur)


def test_torpedo_moving_with_the_current_stays_with_it():
    """Zero relative velocity is an equilibrium: no drag, no Munk moment, no fin lift."""
    cur = (0.5 * np.cos(0.6), 0.5 * np.sin(0.6), 0.0)
    w = _world("alister9", current=CurrentSpec(velocity=cur))
    v = w.vehicles["alister9"]
    from sim.frames import matrix_from_wxyz, wxyz_from_euler

    q = wxyz_from_euler(0.0, 0.0, 0.3)
    v.set_pose((0.0, 0.0, -20.0), q, velocity_body=matrix_from_wxyz(q).T @ np.array(cur))
    w.step(3000)
    np.testing.assert_allclose(v.state().velocity_world, cur, atol=0.005)


def test_varying_current_is_divergence_free_and_has_requested_rms():
    """Stream-function construction: ∂u/∂x + ∂v/∂y = 0 (finite differences); rms ≈ spec."""
    from sim.world.currents import CurrentField

    f = CurrentField(
        CurrentSpec(velocity=(0.1, 0.0, 0.0), variation=0.2, length_scale=30.0, seed=3)
    )
    rng = np.random.default_rng(0)
    p = rng.uniform(-200, 200, (2000, 3))
    e = 1e-3
    ex = np.array([e, 0.0, 0.0])
    ey = np.array([0.0, e, 0.0])
    dx = (f.velocity(p + ex, 10.0) - f.velocity(p - ex, 10.0)) / (2 * e)
    dy = (f.velocity(p + ey, 10.0) - f.velocity(p - ey, 10.0)) / (2 * e)
    div = dx[:, 0] + dy[:, 1]
    assert np.max(np.abs(div)) < 1e-6
    var = f.velocity(p, 10.0) - [0.1, 0.0, 0.0]
    rms = np.sqrt(np.mean(np.sum(var[:, :2] ** 2, axis=1)))
    assert rms == pytest.approx(0.2, rel=0.25)
    assert not np.allclose(f.velocity(p[:5], 0.0), f.velocity(p[:5], 300.0))  # changes in time


def _fossen_rhs(
    h: HydroParams, tau: np.ndarray, vc_world: np.ndarray, rho: float, g: float, fins: tuple = ()
):
    """Second implementation of the 6-DOF model as an ODE in (p, q, ν) for scipy: the
    textbook matrices (M, C_RB, C_A, D, g(η)) built explicitly, no MuJoCo."""
    from sim.frames import matrix_from_wxyz

    M = np.diag(h.rigid_body_mass + h.added_mass)
    Minv = np.linalg.inv(M)

    def skew(a):
        return np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])

    def rhs(t, y):
        q, nu = y[3:7] / np.linalg.norm(y[3:7]), y[7:]
        R = matrix_from_wxyz(q)
        v, w = nu[:3], nu[3:]
        vc = R.T @ vc_world
        vr = v - vc
        nur = np.concatenate([vr, w])
        A11 = np.diag(h.added_mass[:3])
        A22 = np.diag(h.added_mass[3:])
        m = h.mass
        inertia = np.diag(h.inertia)
        C_rb = np.block([[m * skew(w), np.zeros((3, 3))], [np.zeros((3, 3)), -skew(inertia @ w)]])
        C_a = np.block([[np.zeros((3, 3)), -skew(A11 @ vr)], [-skew(A11 @ vr), -skew(A22 @ w)]])
        D = np.diag(h.linear_damping + h.quadratic_damping * np.abs(nur))
        W = m * g
        B = rho * h.volume * g
        fg = R.T @ np.array([0, 0, -W])
        fb = R.T @ np.array([0, 0, B])
        gvec = np.concatenate([fg + fb, np.cross(h.r_cb, fb)])
        acc_c = np.concatenate([-np.cross(w, vc), np.zeros(3)])
        tau_f = np.zeros(6)
        for r_f, n_f, k_f in fins:  # passive fin lift −K|u_r| w_f n, w_f capped at stall
            u = vr[0]
            w_f = n_f @ (vr + np.cross(w, r_f))
            w_f = np.clip(w_f, -0.35 * abs(u), 0.35 * abs(u))
            f = -k_f * abs(u) * w_f * n_f
            tau_f += np.concatenate([f, np.cross(r_f, f)])
        nudot = Minv @ (
            tau + tau_f - C_rb @ nu - C_a @ nur - D @ nur + gvec + np.diag(h.added_mass) @ acc_c
        )
        qd = 0.5 * np.array(
            [
                -q[1] * w[0] - q[2] * w[1] - q[3] * w[2],
                q[0] * w[0] + q[2] * w[2] - q[3] * w[1],
                q[0] * w[1] - q[1] * w[2] + q[3] * w[0],
                q[0] * w[2] + q[1] * w[1] - q[2] * w[0],
            ]
        )
        return np.concatenate([R @ v, qd, nudot])

    return rhs


@pytest.mark.parametrize("kind", ["alister9", "ixn", "naiad", "saga", "rexrov"])
def test_world_trajectory_matches_textbook_fossen_ode(kind):
    """MuJoCo + the applied-force construction reproduces the 6-DOF Fossen model integrated
    by scipy (RK45, tight tolerances) from a tumbling start in a current, under a constant
    body wrench: 5 s, positions within 1 cm, attitude within 0.01 rad (the world uses
    semi-implicit Euler at 0.01 s; 2 cm for the torpedo, whose passive fin lift is added to
    the reference ODE independently)."""
    from sim.frames import wxyz_from_euler

    vk = kind
    cur = np.array([0.3, -0.2, 0.05])
    w = _world(vk, current=CurrentSpec(velocity=tuple(cur)))
    v = w.vehicles[vk]
    h = v.hydro
    q0 = wxyz_from_euler(0.3, -0.2, 0.5)
    nu0 = np.array([0.4, 0.1, -0.05, 0.3, -0.2, 0.25])
    v.set_pose((0.0, 0.0, -20.0), q0, velocity_body=nu0[:3], angular_velocity_body=nu0[3:])
    tau = np.array([8.0, -3.0, 2.0, 0.4, -0.3, 0.6]) * v.hydro.mass / 30.0
    v.set_external_wrench(tau)
    w.step(500)
    s = v.state()
    fins = tuple(
        (np.array(sp.position), np.array(sp.direction), sp.lift_gain)
        for sp in v.model.thruster_specs(
            {n: w.model.site_pos[w.model.site(f"{vk}/{n}").id] for n in v.thruster_names},
            {n: w.thrusters.columns[i, :3] for i, n in enumerate(v.thruster_names)},
            w.water.density,
        )
        if sp.kind == "fin"
    )
    rhs = _fossen_rhs(h, tau, cur, w.water.density, w.water.gravity, fins)
    y0 = np.concatenate([[0.0, 0.0, -20.0], q0, nu0])
    sol = solve_ivp(rhs, (0.0, 5.0), y0, rtol=1e-8, atol=1e-10)
    yT = sol.y[:, -1]
    # the torpedo's fin lift is stiff and explicit: first-order error ≈ 1 cm here
    np.testing.assert_allclose(s.position, yT[:3], atol=0.02 if fins else 0.01)
    from sim.frames import euler_from_wxyz

    np.testing.assert_allclose(s.euler, euler_from_wxyz(yT[3:7]), atol=0.01)


def test_world_converges_to_the_fossen_ode_at_first_order_in_the_timestep():
    """The remaining world-vs-ODE difference is integration error, not a model difference:
    halving the timestep halves it (semi-implicit Euler is first order)."""
    from sim.frames import wxyz_from_euler

    cur = np.array([0.3, -0.2, 0.05])
    errs = []
    for dt in (0.01, 0.005):
        w = build_world(
            WorldSpec(
                seabed=SMALL_SEABED,
                timestep=dt,
                current=CurrentSpec(velocity=tuple(cur)),
                vehicles=(VehicleSpec("alister9", position=(0, 0, -20)),),
            )
        )
        v = w.vehicles["alister9"]
        q0 = wxyz_from_euler(0.3, -0.2, 0.5)
        nu0 = np.array([0.4, 0.1, -0.05, 0.3, -0.2, 0.25])
        v.set_pose((0.0, 0.0, -20.0), q0, velocity_body=nu0[:3], angular_velocity_body=nu0[3:])
        tau = np.array([18.0, -7.0, 4.7, 0.9, -0.7, 1.4])
        v.set_external_wrench(tau)
        w.step(round(5.0 / dt))
        fins = tuple(
            (
                w.model.site_pos[w.model.site(f"alister9/{n}").id].copy(),
                w.thrusters.columns[i, :3].copy(),
                w.thrusters.lift_gain[i],
            )
            for i, n in enumerate(v.thruster_names)
            if w.thrusters.is_fin[i]
        )
        rhs = _fossen_rhs(v.hydro, tau, cur, w.water.density, w.water.gravity, fins)
        sol = solve_ivp(
            rhs, (0.0, 5.0), np.concatenate([[0.0, 0.0, -20.0], q0, nu0]), rtol=1e-8, atol=1e-10
        )
        errs.append(np.abs(v.state().position - sol.y[:3, -1]).max())
    assert errs[0] / errs[1] == pytest.approx(2.0, rel=0.1)
    assert errs[1] < 0.01

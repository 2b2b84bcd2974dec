"""PID: step responses on a first-order plant against closed forms, anti-windup against
the same loop without it, and input validation."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sim.guidance import PID, PIDGains


def simulate_first_order(gains: PIDGains, tau: float, K: float, r: float, T: float, dt=1e-3):
    """Plant tau·y' = -y + K u, discretised exactly for u held over dt (ZOH)."""
    pid = PID(gains)
    a = math.exp(-dt / tau)
    y, ys, us = 0.0, [], []
    pid.max_integral = 0.0
    for _ in range(round(T / dt)):
        u = pid.update(r - y, dt)
        pid.max_integral = max(pid.max_integral, abs(pid.integral))
        y = a * y + (1 - a) * K * u
        ys.append(y)
        us.append(u)
    t = dt * np.arange(1, len(ys) + 1)
    return t, np.array(ys), np.array(us), pid


@settings(max_examples=15, deadline=None)
@given(
    tau=st.floats(0.5, 5.0),
    K=st.floats(0.5, 3.0),
    kp=st.floats(0.5, 5.0),
)
def test_pi_with_pole_zero_cancellation_gives_first_order_closed_loop(tau, K, kp):
    """With T_i = tau the loop is L = K kp/(tau s): closed loop y = r (1 - exp(-K kp t / tau))
    (analytic), to O(dt) of the forward-Euler integrator."""
    g = PIDGains(kp=kp, ki=kp / tau)
    t, y, _, _ = simulate_first_order(g, tau, K, r=1.0, T=3 * tau / (K * kp) + 1.0)
    expected = 1.0 - np.exp(-K * kp * t / tau)
    assert np.max(np.abs(y - expected)) < 5e-3


def test_p_only_steady_state_error_and_time_constant():
    """Analytic: P control of K/(tau s + 1): y_ss = K kp/(1 + K kp), time constant
    tau/(1 + K kp)."""
    tau, K, kp = 2.0, 1.5, 3.0
    t, y, _, _ = simulate_first_order(PIDGains(kp=kp), tau, K, r=1.0, T=5.0)
    yss = K * kp / (1 + K * kp)
    tc = tau / (1 + K * kp)
    np.testing.assert_allclose(y, yss * (1 - np.exp(-t / tc)), atol=2e-3)


def test_anti_windup_reduces_overshoot_and_bounds_integrator():
    """A saturated PI loop (u_max too small to reach r quickly) overshoots far less
    with clamping than without; with it the integral stays within the output range,
    without it it winds up beyond."""
    tau, K = 1.0, 1.0
    base = dict(kp=2.0, ki=4.0, u_min=-1.5, u_max=1.5)
    _, y_aw, u_aw, pid_aw = simulate_first_order(PIDGains(**base), tau, K, r=1.0, T=15.0)
    # pid_aw/pid_nw carry the largest |integral| seen during the run
    _, y_nw, _, pid_nw = simulate_first_order(
        PIDGains(**base, anti_windup=False), tau, K, r=1.0, T=15.0
    )
    ov_aw = y_aw.max() - 1.0
    ov_nw = y_nw.max() - 1.0
    assert ov_nw > 2 * max(ov_aw, 1e-3)
    assert np.all(np.abs(u_aw) <= 1.5 + 1e-12)
    assert pid_aw.max_integral <= 1.5 + 1e-6 < pid_nw.max_integral
    assert abs(y_aw[-1] - 1.0) < 1e-3 and abs(y_nw[-1] - 1.0) < 1e-2  # both settle


def test_derivative_on_measurement_and_feedforward():
    pid = PID(PIDGains(kp=1.0, kd=2.0))
    assert pid.update(1.0, 0.1, error_rate=-0.5, feedforward=3.0) == pytest.approx(1.0 - 1.0 + 3.0)


@pytest.mark.parametrize(
    ("kw", "field"),
    [
        (dict(kp=-1.0), "kp"),
        (dict(kp=1.0, ki=float("nan")), "ki"),
        (dict(kp=1.0, u_min=2.0, u_max=1.0), "u_min"),
    ],
)
def test_gain_validation(kw, field):
    with pytest.raises(ValueError, match=field):
        PIDGains(**kw)


def test_update_rejects_bad_dt_and_nan():
    pid = PID(PIDGains(kp=1.0))
    with pytest.raises(ValueError, match="dt"):
        pid.update(1.0, 0.0)
    with pytest.raises(ValueError, match="error"):
        pid.update(float("nan"), 0.1)

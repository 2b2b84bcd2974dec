"""Datasheet error models and the drift they cause, against independent expectations:
the configured stds over many turn-on draws (χ² bounds), the closed-form drift of a DVL
scale error on a straight line (error = s · distance), the closed form of the matched
odometry covariance for that case (σ_s² d², not the independent-increment σ_s² Σ d_k²),
and scenario validation naming the field."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from sim.frames import wxyz_from_euler
from sim.navigation import (
    AHRS,
    DVL,
    AHRSConfig,
    DVLConfig,
    IMUConfig,
    NavSuite,
    NavSuiteConfig,
)
from sim.navigation.drift import dead_reckoning_drift, lawnmower_states
from sim.scenario.schema import ScenarioError, load_scenario
from sim.state import VehicleState


def _state(t=0.0, yaw=0.0, v=(1.0, 0.0, 0.0), x=0.0):
    return VehicleState(
        t=t,
        position=np.array([x, 0.0, -20.0]),
        quat_wxyz=wxyz_from_euler(0.0, 0.0, yaw),
        velocity_body=np.asarray(v, float),
        angular_velocity_body=np.zeros(3),
        acceleration_body=np.zeros(3),
        water_velocity_world=np.zeros(3),
        altitude=10.0,
    )


def _chi2_ok(x, sigma2, p=1e-4):
    n = len(x)
    q = np.sum(np.asarray(x) ** 2) / sigma2
    return stats.chi2.ppf(p, n) < q < stats.chi2.ppf(1 - p, n)


def test_dvl_turn_on_constants_have_the_datasheet_stds():
    """v = (1+s) Rz(m) v_true + b: over 600 turn-ons, noise-free, v_true = (1, 0, 0):
    x − 1 = s + b_x (var σ_s² + σ_b²), y = m + b_y to first order (var σ_m² + σ_b²)."""
    cfg = DVLConfig.preset("a50", velocity_noise_std=0.0, dropout_prob=0.0)
    v = np.array(
        [DVL(cfg, np.random.default_rng(k)).measure(_state()).velocity_body for k in range(600)]
    )
    assert _chi2_ok(v[:, 0] - 1.0, cfg.scale_factor_std**2 + cfg.velocity_bias_std**2)
    assert _chi2_ok(v[:, 1], cfg.misalignment_std**2 + cfg.velocity_bias_std**2)


def test_ahrs_deviation_rms_over_headings_is_the_configured_heading_rms():
    """Hard/soft-iron coefficients ~ N(0, σ²): the mean square of the yaw error over
    uniformly spread headings, averaged over 300 turn-ons, is σ_1² + σ_2² + σ_d² (+ the
    white noise, switched off); heading_rms says the same."""
    cfg = AHRSConfig.preset("mems_ahrs", yaw_noise_std=0.0)
    headings = np.linspace(-math.pi, math.pi, 16, endpoint=False)
    ms = []
    for k in range(300):
        a = AHRS(cfg, np.random.default_rng(k))
        e = [a.measure(_state(yaw=h)).yaw - h for h in headings]
        ms.append(np.mean(np.angle(np.exp(1j * np.array(e))) ** 2))
    expected = cfg.hard_iron_std**2 + cfg.soft_iron_std**2 + cfg.drift_std**2
    assert expected == pytest.approx(cfg.heading_rms**2)
    assert np.mean(ms) == pytest.approx(expected, rel=0.15)


def _scale_only_suite(sigma_s: float, matched: bool) -> NavSuiteConfig:
    return NavSuiteConfig(
        imu=IMUConfig(
            rate_hz=20.0,
            gyro_noise_density=0.0,
            gyro_bias_rw=0.0,
            gyro_bias_init_std=0.0,
            accel_bias_init_std=0.0,
        ),
        dvl=DVLConfig(
            rate_hz=20.0, velocity_noise_std=0.0, dropout_prob=0.0, scale_factor_std=sigma_s
        ),
        ahrs=None,
        initial_velocity_std=0.0,
        coast_velocity_std=0.0,
        matched_odometry_covariance=matched,
    )


def _straight(n=400, u=1.5, hz=20.0):
    return [_state(t=k / hz, x=u * k / hz, v=(u, 0.0, 0.0)) for k in range(n + 1)]


def _composed_cuts(nav, states, every=4):
    """Poll ``nav`` along ``states`` and compose the odometry cut every ``every`` samples
    as SLAM does: yields (x, var_x), the composed distance along x and its variance,
    after each cut."""
    x, var_x = 0.0, 0.0
    for k, st in enumerate(states):
        nav.poll(st)
        if k and k % every == 0:
            inc = nav.odometry(st.t)
            x += inc.delta[0]
            var_x += inc.cov[0, 0]
            yield x, var_x


@pytest.mark.parametrize("matched", [True, False])
def test_scale_error_drift_and_its_composed_covariance_closed_form(matched):
    """Straight line, only a DVL scale error s: the dead-reckoned distance is (1+s) d
    (drift = |s| · 100 % DT). Composing the increments as SLAM does: the matched Q gives
    var_x = σ_s² d² (the error is common to all increments), the increments' own
    covariance only σ_s² Σ d_k² = σ_s² d²/n (n increments): n times over-confident."""
    sigma_s = 0.004
    states = _straight()
    nav = NavSuite(
        _scale_only_suite(sigma_s, matched),
        np.random.default_rng(1),
        initial_velocity_body=states[0].velocity_body,
    )
    cuts = list(_composed_cuts(nav, states))
    (x, var_x), n = cuts[-1], len(cuts)
    d = states[-1].position[0]
    assert x == pytest.approx((1 + nav.dvl.scale_error) * d, rel=1e-9)
    # linearized at the measured velocity: the dead-reckoned distance x = (1+s) d
    expected = (sigma_s * x) ** 2 if matched else (sigma_s * x) ** 2 / n
    assert var_x == pytest.approx(expected, rel=1e-6)


def test_matched_covariance_after_a_shrinking_error_is_not_added_again():
    """Out and back along x (yaw 0, reversing) five times 30 m, only a DVL scale error
    s: the dead-reckoned error is s · x(t), its variance σ_s² x² shrinks to 0 at every
    return. Composing the clipped matched Q as SLAM does gives at each cut max over the
    past of σ_s² x² (conservative, never below the truth) — σ_s² d² at the last far
    end, not 3 σ_s² d² (each outward leg's growth added again)."""
    sigma_s, u, hz, leg_n = 0.004, 1.5, 20.0, 400
    xs = np.concatenate([np.arange(leg_n) * u / hz, leg_n * u / hz - np.arange(leg_n) * u / hz])
    xs = np.concatenate([xs, xs, np.arange(leg_n + 1) * u / hz])
    vs = np.where(np.diff(xs, append=np.inf) >= 0, u, -u)
    states = [_state(t=k / hz, x=x, v=(v, 0.0, 0.0)) for k, (x, v) in enumerate(zip(xs, vs))]
    nav = NavSuite(
        _scale_only_suite(sigma_s, True),
        np.random.default_rng(2),
        initial_velocity_body=states[0].velocity_body,
    )
    x_max = 0.0
    for x, var_x in _composed_cuts(nav, states):
        x_max = max(x_max, abs(x))
        assert var_x >= (sigma_s * x) ** 2 * (1 - 1e-6)
    assert var_x == pytest.approx((sigma_s * x_max) ** 2, rel=1e-3)


def test_matched_covariance_keeps_the_lawnmower_drift_consistent():
    """MEMS AHRS + DVL (alister9 payload) on a short lawnmower, 6 seeds: the final-pose
    NEES against the composed matched covariance averages below the χ²₃ 99.9 % point of
    a 6-run mean (no over-confidence), and the drift is of the DVL + AHRS class
    (0.1-3 % DT)."""
    from sim.scenario.schema import NavSpec

    cfg = NavSpec(kind="alister9").suite_config()
    states = lawnmower_states(1.5, leg_m=40.0, n_legs=2, dt=0.1)
    res = [dead_reckoning_drift(cfg, states, np.random.default_rng(s)) for s in range(6)]
    nees = np.array([r.nees_final for r in res])
    assert nees.sum() < stats.chi2.ppf(0.999, 3 * len(nees))
    assert 0.1 < np.median([r.drift_pct for r in res]) < 3.0


def test_scenario_rejects_a_mission_above_the_dvl_lock_window():
    with pytest.raises(ScenarioError, match=r"vehicles\[0\]\.mission\.altitude_m.*nav\.dvl"):
        load_scenario("dense-loop", {"vehicles[0].nav.dvl.max_altitude": 5.0})


def test_scenario_rejects_a_vehicle_without_heading_source_but_takes_a_fog():
    with pytest.raises(ScenarioError, match=r"vehicles\[0\]\.nav.*no heading source"):
        load_scenario("dense-loop", {"vehicles[0].nav.ahrs.enabled": False})
    s = load_scenario(
        "dense-loop",
        {"vehicles[0].nav.ahrs.enabled": False, "vehicles[0].nav.imu.preset": "tactical"},
    )
    assert s.vehicles[0].nav.suite_config().ahrs is None


def test_sensor_parameters_out_of_range_name_the_field():
    with pytest.raises(ScenarioError, match=r"vehicles\[0\]\.nav\.dvl.*scale_factor_std"):
        load_scenario("dense-loop", {"vehicles[0].nav.dvl.scale_factor_std": 0.5})
    with pytest.raises(ValueError, match=r"AHRSConfig\.hard_iron_std"):
        AHRSConfig(hard_iron_std=-0.01)


def test_navigation_state_is_the_dead_reckoned_pose_not_the_truth():
    """The autopilot's view: x, y, yaw from the suite's own pose, depth from the depth
    sensor; a suite started 3 m off the truth reports that offset."""
    cfg = NavSuiteConfig(imu=IMUConfig.preset("tactical"))
    nav = NavSuite(cfg, np.random.default_rng(0), initial_pose=np.array([3.0, 0.0, 0.0]))
    st = _state(yaw=0.0)
    nav.poll(st)
    ns = nav.navigation_state(st)
    assert ns.position[0] == pytest.approx(3.0)
    assert ns.euler[2] == pytest.approx(nav.pose()[2], abs=1e-12)
    assert ns.depth == pytest.approx(20.0, abs=0.2)

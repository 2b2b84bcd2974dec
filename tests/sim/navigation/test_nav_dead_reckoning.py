"""Dead reckoning: the propagated covariance against closed forms (white velocity noise
integrates to n σ² h²; angle random walk: var = N² T) and against Monte Carlo over
seeds (NEES of the accumulated error inside the χ²(3N) bound), and drift scaling
linearly with the configured sensor noise."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from sim.frames import wxyz_from_euler
from sim.navigation import (
    DeadReckoner,
    DeadReckoningConfig,
    DVLConfig,
    IMUConfig,
    NavSuite,
    NavSuiteConfig,
    OdometryIncrement,
    true_increment,
)
from sim.state import VehicleState

U = 1.5  # m/s
R_YAW = 0.04  # rad/s
CTRL_HZ = 20.0


def arc_states(duration, u=U, r=R_YAW, hz=CTRL_HZ, yaw0=0.3, altitude=15.0):
    """Exact constant-speed, constant-turn-rate trajectory at the control rate."""
    out = []
    for k in range(round(duration * hz) + 1):
        t = k / hz
        yaw = yaw0 + r * t
        if abs(r) > 0:
            x = u / r * (math.sin(yaw) - math.sin(yaw0))
            y = -u / r * (math.cos(yaw) - math.cos(yaw0))
        else:
            x, y = u * t * math.cos(yaw0), u * t * math.sin(yaw0)
        out.append(
            VehicleState(
                t=t,
                position=np.array([x, y, -20.0]),
                quat_wxyz=wxyz_from_euler(0.0, 0.0, yaw),
                velocity_body=np.array([u, 0.0, 0.0]),
                angular_velocity_body=np.array([0.0, 0.0, r]),
                acceleration_body=np.array([0.0, u * r, 0.0]),
                water_velocity_world=np.zeros(3),
                altitude=altitude,
            )
        )
    return out


def pose2d(s: VehicleState):
    return np.array([s.position[0], s.position[1], s.euler[2]])


def run_dr(states, cfg: NavSuiteConfig, seed, cut_every=None):
    """Fly the states through the nav suite; return list of (increment, truth)."""
    # the run starts under way: the dead reckoner knows the start velocity to 2 cm/s
    suite = NavSuite(
        cfg,
        np.random.default_rng(seed),
        t0=states[0].t,
        initial_velocity_body=states[0].velocity_body,
    )
    cut_every = cut_every or len(states) - 1
    out = []
    start = states[0]
    for k, s in enumerate(states):
        suite.poll(s)
        if k > 0 and k % cut_every == 0:
            out.append((suite.odometry(s.t), true_increment(pose2d(start), pose2d(s))))
            start = s
    return out


def suite_cfg(dvl_std=0.01, gyro_density=1e-3, dropout=0.0, bias0=0.0, aiding=False):
    """Gyro-only heading by default (these tests check the DVL + gyro mechanisation and
    its closed forms; compass aiding is tested in test_nav_consumer_imu.py), white DVL
    noise only (the turn-on constants and the matched covariance have their own tests
    in test_nav_drift.py), each increment with its own marginal covariance."""
    return NavSuiteConfig(
        heading_aiding=aiding,
        matched_odometry_covariance=False,
        imu=IMUConfig(
            rate_hz=CTRL_HZ,
            gyro_noise_density=gyro_density,
            gyro_bias_rw=0.0,
            gyro_bias_init_std=bias0,
            accel_bias_init_std=0.0,
        ),
        dvl=DVLConfig.preset(
            "rdi600",
            velocity_noise_std=dvl_std,
            dropout_prob=dropout,
            scale_factor_std=0.0,
            misalignment_std=0.0,
            velocity_bias_std=0.0,
        ),
        initial_velocity_std=0.02,
    )


def test_straight_line_covariance_closed_form():
    """Straight line, DVL only: n pings at spacing h, cut at n h. Trapezoid between
    pings plus the held last ping give the pings weights h/2, h, …, h, 3h/2, so
    var(dx) = var(dy) = σ² h² (n − 2 + 1/4 + 9/4) = σ² h² (n + 1/2); no correlation
    with dphi without gyro noise."""
    dr = DeadReckoner(DeadReckoningConfig(dvl_velocity_std=0.02, gyro_sample_std=0.0))
    from sim.navigation import DVLMeasurement

    h, n = 0.2, 50
    for k in range(n):
        dr.add(
            DVLMeasurement(t=k * h, velocity_body=np.array([2.0, 0, 0]), valid=True, altitude=10)
        )
    inc = dr.increment(n * h)
    np.testing.assert_allclose(inc.delta, [2.0 * n * h, 0, 0], atol=1e-12)
    np.testing.assert_allclose(
        np.diag(inc.cov), [(n + 0.5) * 0.02**2 * h**2] * 2 + [0.0], rtol=1e-12
    )


def test_gyro_only_heading_variance_is_angle_random_walk():
    """ARW definition: after T seconds the heading std is N·√T (N = noise density), up
    to the discretisation (trapezoid weights as in the DVL case: var = N² T (1 + 1/(2n)));
    the lateral position variance of a straight run of speed u is u² N² T³/3
    (integrated random walk), to O(h/T)."""
    from sim.navigation import DVLMeasurement, IMUMeasurement

    N, rate, T, u = 1e-3, 50.0, 20.0, 2.0
    dr = DeadReckoner(
        DeadReckoningConfig(dvl_velocity_std=0.0, gyro_sample_std=N * math.sqrt(rate))
    )
    dr.add(DVLMeasurement(t=0.0, velocity_body=np.array([u, 0, 0]), valid=True, altitude=10))
    for k in range(int(T * rate)):
        dr.add(IMUMeasurement(t=k / rate, gyro=np.zeros(3), specific_force=np.zeros(3)))
    inc = dr.increment(T)
    n = round(T * rate)
    assert inc.cov[2, 2] == pytest.approx(N**2 * T * (1 + 0.5 / n), rel=1e-9)
    assert inc.cov[1, 1] == pytest.approx(u**2 * N**2 * T**3 / 3, rel=0.01)


N_RUNS = 120


def _errors(cfg, n_runs=N_RUNS, duration=12.0, cut_every=None, seed0=0):
    states = arc_states(duration)
    errs, covs = [], []
    for seed in range(seed0, seed0 + n_runs):
        for inc, truth in run_dr(states, cfg, seed, cut_every):
            assert isinstance(inc, OdometryIncrement)
            e = inc.delta - truth
            e[2] = (e[2] + math.pi) % (2 * math.pi) - math.pi
            errs.append(e)
            covs.append(inc.cov)
    return np.array(errs), np.array(covs)


@pytest.fixture(scope="module")
def mc_base():
    # dropouts and a turn-on gyro bias included: both are in the propagated covariance
    return _errors(suite_cfg(dvl_std=0.02, gyro_density=2e-3, dropout=0.2, bias0=2e-3))


def test_monte_carlo_nees_inside_chi2_bound(mc_base):
    """Σ eᵢᵀ Pᵢ⁻¹ eᵢ over N independent seeded runs is χ²(3N) if the propagated covariance
    is right; two-sided 99.9 % bound. Also per-axis: empirical variance over runs vs
    the mean propagated variance, χ²(N) bound."""
    errs, covs = mc_base
    nees = np.einsum("ni,nij,nj->n", errs, np.linalg.inv(covs), errs).sum()
    dof = 3 * len(errs)
    assert stats.chi2.ppf(5e-4, dof) < nees < stats.chi2.ppf(1 - 5e-4, dof), nees / len(errs)
    for k in range(3):
        q = np.sum(errs[:, k] ** 2) / covs[:, k, k].mean()
        assert stats.chi2.ppf(5e-4, len(errs)) < q < stats.chi2.ppf(1 - 5e-4, len(errs))


def test_drift_grows_proportionally_with_sensor_noise(mc_base):
    """Linearity: doubling the DVL and gyro noise (and bias) doubles the drift std. The
    empirical std ratio must be 2 within the sampling error of two N-run variances
    (F-distribution bound), and the propagated covariance must scale by 4."""
    errs1, covs1 = mc_base
    # independent seeds: the two Monte Carlo sets are independent samples (F test)
    errs2, covs2 = _errors(
        suite_cfg(dvl_std=0.04, gyro_density=4e-3, dropout=0.2, bias0=4e-3), seed0=10_000
    )
    np.testing.assert_allclose(
        covs2.mean(0)[[0, 1, 2], [0, 1, 2]] / covs1.mean(0)[[0, 1, 2], [0, 1, 2]], 4.0, rtol=0.15
    )
    n = len(errs1)
    for k in range(3):
        ratio = np.mean(errs2[:, k] ** 2) / np.mean(errs1[:, k] ** 2) / 4.0
        lo, hi = stats.f.ppf([5e-4, 1 - 5e-4], n, n)
        assert lo < ratio < hi, (k, ratio)
    assert np.mean(np.hypot(errs2[:, 0], errs2[:, 1])) > 1.5 * np.mean(
        np.hypot(errs1[:, 0], errs1[:, 1])
    )


def test_cut_intervals_are_consistent_and_sum_to_whole():
    """Cutting the same run into 4 intervals: each increment passes the per-interval NEES
    bound, and composing the increments (SLAM predict, eq. 5.21) reproduces the single
    whole-run increment of an identical-seed run exactly."""
    cfg = suite_cfg(dvl_std=0.02, gyro_density=2e-3)
    states = arc_states(12.0)
    parts = run_dr(states, cfg, seed=7, cut_every=60)
    whole = run_dr(states, cfg, seed=7)[0][0]
    x = np.zeros(3)
    for inc, _ in parts:
        c, s = math.cos(x[2]), math.sin(x[2])
        x = x + np.array(
            [c * inc.delta[0] - s * inc.delta[1], s * inc.delta[0] + c * inc.delta[1], inc.delta[2]]
        )
    np.testing.assert_allclose(x, whole.delta, atol=1e-9)
    errs, covs = _errors(cfg, n_runs=40, cut_every=60)
    nees = np.einsum("ni,nij,nj->n", errs, np.linalg.inv(covs), errs).sum()
    dof = 3 * len(errs)
    assert stats.chi2.ppf(5e-4, dof) < nees < stats.chi2.ppf(1 - 5e-4, dof)


def test_dead_reckoner_rejects_time_going_backwards():
    from sim.navigation import DVLMeasurement

    dr = DeadReckoner(DeadReckoningConfig(dvl_velocity_std=0.01, gyro_sample_std=0.0), t0=5.0)
    with pytest.raises(ValueError, match="before"):
        dr.add(DVLMeasurement(t=4.0, velocity_body=np.zeros(3), valid=True, altitude=1.0))
    with pytest.raises(ValueError, match="dvl_velocity_std"):
        DeadReckoningConfig(dvl_velocity_std=-1.0, gyro_sample_std=0.0)

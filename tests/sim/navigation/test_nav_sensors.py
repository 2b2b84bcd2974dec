"""Nav sensors: noise statistics against their configured values (χ²/binomial bounds on
seeded samples), gravity in the specific force (analytic), lock windows, rate and delay
scheduling (exact arithmetic), config validation."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from sim.frames import wxyz_from_euler
from sim.navigation import (
    AHRS,
    DVL,
    GPS,
    IMU,
    AHRSConfig,
    DepthConfig,
    DepthSensor,
    DVLConfig,
    GPSConfig,
    IMUConfig,
)
from sim.state import VehicleState


def make_state(
    t=0.0, pos=(0, 0, -10), rpy=(0, 0, 0), v=(0, 0, 0), w=(0, 0, 0), a=(0, 0, 0), altitude=20.0
):
    return VehicleState(
        t=t,
        position=np.asarray(pos, float),
        quat_wxyz=wxyz_from_euler(*rpy),
        velocity_body=np.asarray(v, float),
        angular_velocity_body=np.asarray(w, float),
        acceleration_body=np.asarray(a, float),
        water_velocity_world=np.zeros(3),
        altitude=altitude,
    )


def var_in_chi2_bound(samples, sigma, p=1e-4):
    """Sample variance consistent with sigma²: (n-1) s²/σ² inside the two-sided χ² bound."""
    n = len(samples)
    q = (n - 1) * np.var(samples, ddof=1) / sigma**2
    return stats.chi2.ppf(p, n - 1) < q < stats.chi2.ppf(1 - p, n - 1)


def test_imu_level_at_rest_reads_plus_g_and_configured_white_noise():
    """Specific force of a level vehicle at rest is +g along body z (accelerometer
    measures the reaction to gravity); noise std = density·√rate."""
    cfg = IMUConfig.preset(
        "consumer",
        gyro_bias_init_std=0.0,
        accel_bias_init_std=0.0,
        gyro_bias_rw=0.0,
        accel_bias_rw=0.0,
    )
    imu = IMU(cfg, np.random.default_rng(1))
    ms = [imu.measure(make_state(t=k / cfg.rate_hz)) for k in range(2000)]
    f = np.array([m.specific_force for m in ms])
    g = np.array([m.gyro for m in ms])
    sig_a = cfg.accel_noise_density * math.sqrt(cfg.rate_hz)
    sig_g = cfg.gyro_noise_density * math.sqrt(cfg.rate_hz)
    np.testing.assert_allclose(f.mean(0), [0, 0, cfg.gravity], atol=5 * sig_a / math.sqrt(2000))
    for k in range(3):
        assert var_in_chi2_bound(f[:, k], sig_a)
        assert var_in_chi2_bound(g[:, k], sig_g)


@pytest.mark.parametrize(
    ("rpy", "expected"),
    [((math.pi / 2, 0, 0), (0, 1, 0)), ((0, math.pi / 2, 0), (-1, 0, 0)), ((0, 0, 1.0), (0, 0, 1))],
)
def test_imu_gravity_rotates_into_body_frame(rpy, expected):
    """Analytic: f = Rᵀ(0,0,g). Roll +90° (port side up) puts +g on body y; pitch +90°
    (nose down, FLU frame) puts -g on body x; yaw does not change it."""
    cfg = IMUConfig(
        gyro_noise_density=0,
        accel_noise_density=0,
        gyro_bias_rw=0,
        accel_bias_rw=0,
        gyro_bias_init_std=0,
        accel_bias_init_std=0,
    )
    m = IMU(cfg, np.random.default_rng(0)).measure(make_state(rpy=rpy, a=(0.5, 0, 0)))
    exp = cfg.gravity * np.array(expected, float) + np.array([0.5, 0, 0])
    np.testing.assert_allclose(m.specific_force, exp, atol=1e-9)


def test_imu_bias_random_walk_increments_have_configured_variance():
    """Bias increments over Δt are N(0, B²Δt) (definition of a random walk)."""
    cfg = IMUConfig(
        rate_hz=10.0,
        gyro_noise_density=0,
        accel_noise_density=0,
        gyro_bias_rw=1e-3,
        accel_bias_rw=2e-3,
    )
    imu = IMU(cfg, np.random.default_rng(2))
    b = []
    for k in range(1500):
        imu.measure(make_state(t=k * 0.1))
        b.append(np.concatenate([imu.gyro_bias, imu.accel_bias]))
    d = np.diff(np.array(b), axis=0)
    assert var_in_chi2_bound(d[:, 2], 1e-3 * math.sqrt(0.1))
    assert var_in_chi2_bound(d[:, 3], 2e-3 * math.sqrt(0.1))


def test_dvl_lock_window_dropouts_and_noise():
    """No lock above max_altitude / below min_altitude / unknown altitude; dropout
    fraction inside the window within a 4σ binomial bound; velocity noise std as set
    (the turn-on constants switched off: they have their own test)."""
    cfg = DVLConfig.preset(
        "rdi600",
        dropout_prob=0.1,
        scale_factor_std=0.0,
        misalignment_std=0.0,
        velocity_bias_std=0.0,
    )
    dvl = DVL(cfg, np.random.default_rng(3))
    v = (1.2, -0.1, 0.05)
    assert not dvl.measure(make_state(v=v, altitude=cfg.max_altitude + 1)).valid
    assert not dvl.measure(make_state(v=v, altitude=0.2)).valid
    assert dvl.measure(make_state(v=v, altitude=float("nan"))).velocity_body is None
    ms = [dvl.measure(make_state(v=v, altitude=30.0)) for _ in range(3000)]
    ok = np.array([m.valid for m in ms])
    drop = 1 - ok.mean()
    assert abs(drop - 0.1) < 4 * math.sqrt(0.1 * 0.9 / 3000)
    vel = np.array([m.velocity_body for m in ms if m.valid])
    np.testing.assert_allclose(
        vel.mean(0), v, atol=5 * cfg.velocity_noise_std / math.sqrt(len(vel))
    )
    assert var_in_chi2_bound(vel[:, 0] - v[0], cfg.velocity_noise_std)


def test_depth_bias_noise_and_quantization():
    cfg = DepthConfig(noise_std=0.05, bias=0.3, resolution=0.01)
    s = DepthSensor(cfg, np.random.default_rng(4))
    d = np.array([s.measure(make_state(pos=(0, 0, -12.0))).depth for _ in range(2000)])
    assert abs(d.mean() - 12.3) < 5 * 0.05 / math.sqrt(2000)
    np.testing.assert_allclose(d / 0.01, np.round(d / 0.01), atol=1e-6)  # on the grid
    assert var_in_chi2_bound(d, math.sqrt(0.05**2 + 0.01**2 / 12))  # + quantization noise


def test_ahrs_yaw_wraps_and_has_configured_noise():
    cfg = AHRSConfig(yaw_noise_std=0.05, roll_pitch_noise_std=0.01, yaw_bias=0.1)
    s = AHRS(cfg, np.random.default_rng(5))
    ms = [s.measure(make_state(rpy=(0.1, -0.2, math.pi - 0.01))) for _ in range(2000)]
    yaw = np.array([m.yaw for m in ms])
    assert np.all((yaw > -math.pi) & (yaw <= math.pi))
    err = np.angle(np.exp(1j * (yaw - (math.pi - 0.01))))
    assert abs(err.mean() - 0.1) < 5 * 0.05 / math.sqrt(2000)
    assert var_in_chi2_bound(err, 0.05)
    assert var_in_chi2_bound(np.array([m.roll for m in ms]) - 0.1, 0.01)


def test_gps_only_at_surface():
    cfg = GPSConfig(horizontal_noise_std=1.0, max_depth=0.5)
    g = GPS(cfg, np.random.default_rng(6))
    assert g.measure(make_state(pos=(3, 4, -0.2))).valid
    m = g.measure(make_state(pos=(3, 4, -0.8)))
    assert not m.valid and m.position_xy is None


def test_rate_and_delay_schedule():
    """Exact: a 5 Hz sensor polled at 50 Hz samples on every 10th tick; with 0.3 s
    delay the sample taken at t is delivered on the first tick >= t + 0.3."""
    s = DepthSensor(DepthConfig(rate_hz=5.0, delay_s=0.3, noise_std=0.0), np.random.default_rng(0))
    got = []
    for k in range(100):
        t = k * 0.02
        for m in s.poll(make_state(t=t)):
            got.append((round(t, 6), round(m.t, 6)))
    acquired = [a for _, a in got]
    np.testing.assert_allclose(np.diff(acquired), 0.2, atol=1e-9)
    for delivered, a in got:
        assert delivered == pytest.approx(a + 0.3, abs=1e-9)


@pytest.mark.parametrize(
    ("factory", "field", "value"),
    [
        (IMUConfig, "rate_hz", 0.0),
        (IMUConfig, "gyro_noise_density", -1e-3),
        (DVLConfig, "velocity_noise_std", -0.1),
        (DVLConfig, "dropout_prob", 1.5),
        (DepthConfig, "noise_std", -1.0),
        (AHRSConfig, "rate_hz", -5.0),
        (GPSConfig, "delay_s", float("nan")),
    ],
)
def test_config_validation_names_field(factory, field, value):
    with pytest.raises(ValueError, match=field):
        factory(**{field: value})


def test_unknown_preset_lists_allowed():
    with pytest.raises(ValueError, match="tactical"):
        IMUConfig.preset("navy")
    assert (
        IMUConfig.preset("tactical").gyro_noise_density
        < IMUConfig.preset("consumer").gyro_noise_density
    )

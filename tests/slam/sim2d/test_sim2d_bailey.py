"""Bailey's simulator reimplemented: facts measured on the original (REFERENCE.md),
steering limits, the sensor footprint, and the composed odometry against step-by-step
EKF predictions (a second implementation)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from slam.estimators.aekf import compose_odometry, predict
from slam.sim2d import (
    Sim2DConfig,
    compose_increments,
    dense_loop_map,
    line_map,
    range_bearing,
    segmentation_loop_map,
    simulate_run,
    step_odometry,
    true_path,
    visible_mask,
)


def test_original_simulator_facts_on_example_webmap():
    """REFERENCE.md, measured by running Bailey's MATLAB: two loops of example_webmap at
    dt 0.025 take 17,382 control steps and 1,931 scans (every 9 steps, not 8), and
    landmark columns 19, 20, 21, 31, 34 (1-based) are never inside the sensor footprint."""
    m = dense_loop_map()
    tp = true_path(m.waypoints, Sim2DConfig())
    assert tp.n_steps == 17_382
    assert tp.scan_steps.size == 1_931
    assert np.all(np.diff(tp.scan_steps) == 9)
    seen = visible_mask(tp.poses, m.landmarks, 30.0).any(axis=0)
    assert (np.flatnonzero(~seen) + 1).tolist() == [19, 20, 21, 31, 34]


def test_half_dt_variant_scans_every_nine_steps_too():
    """dt 0.0125: 8 × 0.0125 also sums to just under 0.1 → a scan every 0.1125 s."""
    tp = true_path(dense_loop_map().waypoints, Sim2DConfig(dt_s=0.0125))
    assert np.all(np.diff(tp.scan_steps) == 9)
    assert 2 * 17_382 - 50 < tp.n_steps < 2 * 17_382 + 50


def test_steering_respects_rate_and_angle_limits():
    cfg = Sim2DConfig()
    tp = true_path(dense_loop_map().waypoints, cfg)
    assert np.abs(tp.steer).max() <= cfg.max_steer_rad + 1e-12
    dG = np.diff(np.concatenate([[0.0], tp.steer]))
    assert np.abs(dG).max() <= cfg.steer_rate_radps * cfg.dt_s + 1e-12
    step = np.hypot(*np.diff(tp.poses[:, :2], axis=0).T)
    np.testing.assert_allclose(step, cfg.speed_mps * cfg.dt_s, rtol=1e-12)


def test_visible_mask_forward_half_disc():
    pose = np.array([[0.0, 0.0, math.pi / 2]])  # facing +y
    lm = np.array([[0.0, 10.0], [0.0, -10.0], [29.0, 1.0], [0.0, 31.0], [5.0, 0.5]])
    assert visible_mask(pose, lm, 30.0)[0].tolist() == [True, False, True, False, True]
    z = range_bearing(pose[0], lm[:1])
    np.testing.assert_allclose(z, [[10.0, 0.0]], atol=1e-12)


def test_composed_increments_equal_sequential_predictions(rng):
    """compose_increments (vectorized, all segments) = folding compose_odometry = one EKF
    prediction per step."""
    cfg = Sim2DConfig()
    V = 3.0 + 0.3 * rng.standard_normal(20)
    G = 0.2 + 0.05 * rng.standard_normal(20)
    u, Q = step_odometry(V, G, cfg)
    us, Qs = compose_increments(u, Q, np.array([0, 9, 12]))
    x = np.array([1.0, 2.0, 0.3, 5.0, 6.0])
    P = np.diag([0.01, 0.02, 0.003, 0.5, 0.5])
    for seg, (a, b) in enumerate([(0, 9), (9, 12), (12, 20)]):
        uc, Qc = u[a], Q[a]
        xs, Ps = predict(x, P, u[a], Q[a])
        for k in range(a + 1, b):
            uc, Qc = compose_odometry(uc, Qc, u[k], Q[k])
            xs, Ps = predict(xs, Ps, u[k], Q[k])
        np.testing.assert_allclose(us[seg], uc, atol=1e-12)
        np.testing.assert_allclose(Qs[seg], Qc, atol=1e-15)
        xc, Pc = predict(x, P, us[seg], Qs[seg])
        np.testing.assert_allclose(xc, xs, atol=1e-11)
        np.testing.assert_allclose(Pc, Ps, atol=1e-13)
        x, P = xs, Ps


def test_step_odometry_noise_matches_declared_covariance():
    """Monte Carlo: increments from noisy controls scatter with the declared first-order
    covariance (σ_v, σ_G small against the increment's nonlinearity)."""
    cfg = Sim2DConfig()
    rng = np.random.default_rng(7)
    n = 200_000
    V = cfg.speed_mps + cfg.sigma_v_mps * rng.standard_normal(n)
    G = 0.3 + cfg.sigma_steer_rad * rng.standard_normal(n)
    u, _ = step_odometry(V, G, cfg)
    _, Q0 = step_odometry(np.array([cfg.speed_mps]), np.array([0.3]), cfg)
    C = np.cov(u.T)
    np.testing.assert_allclose(C, Q0[0], rtol=0.03, atol=1e-12)


def test_runs_are_seeded_and_labels_identify_landmarks():
    m = dense_loop_map()
    cfg = Sim2DConfig(n_loops=1)
    a = simulate_run(m.landmarks, m.waypoints, cfg, np.random.default_rng(3))
    b = simulate_run(m.landmarks, m.waypoints, cfg, np.random.default_rng(3))
    c = simulate_run(m.landmarks, m.waypoints, cfg, np.random.default_rng(4))
    np.testing.assert_array_equal(a.obs_z, b.obs_z)
    np.testing.assert_array_equal(a.odom_u, b.odom_u)
    assert not np.array_equal(a.obs_z, c.obs_z)
    # noise-free observations equal the exact range-bearing of the labelled landmark
    q = simulate_run(m.landmarks, m.waypoints, cfg, np.random.default_rng(0), sensor_noise=False)
    i = 100
    z, lab = q.scan(i)
    np.testing.assert_allclose(z, range_bearing(q.true_poses[i], m.landmarks[lab]), atol=1e-12)
    assert len(q.observations(i)) == z.shape[0]
    # noise-free odometry integrates to the true path
    q0 = simulate_run(m.landmarks, m.waypoints, cfg, np.random.default_rng(0), control_noise=False)
    x = np.zeros(3)
    for k in range(q0.n_scans):
        x, _ = predict(x, np.zeros((3, 3)), q0.odom_u[k], q0.odom_Q[k])
    err = q0.true_poses[-1] - x
    assert np.hypot(err[0], err[1]) < 1e-8


def test_generated_maps_match_the_thesis_description():
    line = line_map()
    assert line.landmarks.shape == (27, 2) and line.waypoints.shape == (4, 2)
    assert np.all(line.waypoints[:, 1] == 0.0)
    assert line.landmarks[:, 0].min() >= 0 and line.landmarks[:, 0].max() <= 1000
    assert np.abs(line.landmarks[:, 1]).max() <= 400
    seg = segmentation_loop_map()
    assert seg.landmarks.shape == (54, 2)
    assert np.any(np.all(np.isclose(seg.landmarks, [53.5, 60.3]), axis=1))
    assert np.any(np.all(np.isclose(seg.landmarks, [-106.55, -81.13]), axis=1))
    np.testing.assert_array_equal(line_map().landmarks, line.landmarks)  # fixed default seed


def test_bad_config_and_rng_rejected():
    with pytest.raises(ValueError, match="dt_s"):
        Sim2DConfig(dt_s=0.0)
    with pytest.raises(ValueError, match="sigma_r_m"):
        Sim2DConfig(sigma_r_m=-0.1)
    m = dense_loop_map()
    with pytest.raises(ValueError, match="Generator"):
        simulate_run(m.landmarks, m.waypoints, Sim2DConfig(), 42)


def test_odometry_bias_of_the_reference_and_its_correction():
    """E[cos(G + ε)] = cos(G) exp(-σ²/2): Bailey's odometry is short by that factor on
    average; unbiased_odometry=True removes it. Monte Carlo over the straight steps of the
    line map with the speed noise off, so the 0.14 % bias stands far above the sampling
    error (std of cos ε is σ²/√2)."""
    m = line_map()
    cfg_b = Sim2DConfig(n_loops=1, sigma_v_mps=0.0)
    cfg_f = Sim2DConfig(n_loops=1, sigma_v_mps=0.0, unbiased_odometry=True)
    biased = simulate_run(m.landmarks, m.waypoints, cfg_b, np.random.default_rng(0))
    fixed = simulate_run(m.landmarks, m.waypoints, cfg_f, np.random.default_rng(0))
    tp = true_path(m.waypoints, cfg_b)
    straight = np.abs(tp.steer) < 1e-9
    step = cfg_b.speed_mps * cfg_b.dt_s
    factor = math.exp(-0.5 * cfg_b.sigma_steer_rad**2)
    se = cfg_b.sigma_steer_rad**2 / math.sqrt(2 * straight.sum())
    assert straight.sum() > 10_000
    assert 1.0 - factor > 20 * se
    assert abs(biased.step_u[straight, 0].mean() / step - factor) < 4 * se
    assert abs(fixed.step_u[straight, 0].mean() / step - 1.0) < 4 * se

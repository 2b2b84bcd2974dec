"""Consumer-grade MEMS IMU (the NavSuite default) with the AHRS yaw fused into the dead
reckoner's heading, on simulated dynamics: an alister9 flown by its autopilot around a
rectangle in MuJoCo (60 s, two 90° turns, real pitch/roll/speed transients).

Independent expectations:
* χ² consistency (seeded Monte Carlo over sensor noise on the same true trajectory): the
  NEES of the 5 s increments summed over runs is χ²(3N); so is that of one 60 s
  increment, χ²(3R); the gyro-bias estimate's normalized error is χ²(R) (two-sided
  99.9 % bounds). The 60 s pose obtained by composing the 5 s increments as a SLAM
  predict does (first-order compounding, REFERENCE.md eqs. 5.21–5.27, increments
  independent) stays under the χ² upper bound (conservative, see the test).
* The bug this guards against, shown by the same statistic: the consumer gyro's
  turn-on bias (~0.3 °/s) integrated without the compass drifts the heading by ~10–20°
  a minute while the composed covariance, which cannot represent an error common to all
  increments, stays near a degree: NEES far above the χ² upper bound.
* Compass fusion closed form: a static vehicle with a noise-free gyro averaging n compass
  samples of variance σ² has heading variance σ²/n (mean of n independent samples).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from sim.navigation import (
    AHRSConfig,
    AHRSMeasurement,
    DeadReckoner,
    DeadReckoningConfig,
    DVLConfig,
    IMUConfig,
    IMUMeasurement,
    NavSuite,
    NavSuiteConfig,
    true_increment,
)

DT = 0.05  # control / nav tick, s
DURATION = 60.0
SETTLE = 10.0  # flown before the nav suite starts: the vehicle is under way
CUT_S = 5.0
N_RUNS = 40
# The DVL reports interval means here: with instantaneous samples, MuJoCo's semi-implicit
# step (pose moved by the post-step velocity) leaves a deterministic 2–7 mm error per 5 s
# in turns and speed changes, against a 5 mm σ of the rdi600 DVL — a simulator artefact
# that would mask the IMU/compass statistics this file tests.
# white-noise sensors only (the turn-on constants, compass deviation and the matched
# covariance are tested in test_nav_drift.py): this module checks the aided mechanisation
DVL_MEAN = DVLConfig.preset(
    "rdi600", averaged=True, scale_factor_std=0.0, misalignment_std=0.0, velocity_bias_std=0.0
)
AHRS_WHITE = AHRSConfig.preset(
    "mems_ahrs",
    yaw_noise_std=math.radians(1.0),
    hard_iron_std=0.0,
    soft_iron_std=0.0,
    drift_std=0.0,
)


# flat bottom on a 2 m grid: the 0.25 m default makes a mesh of ~0.4 M vertices
# (160 m square) that costs seconds of MuJoCo compile per world; nothing here needs it
@pytest.fixture(scope="module")
def flown_states():
    """True states of an alister9 flying a 40 m x 25 m loop at cruise speed, 20 Hz, from
    SETTLE s after launch (at cruise speed) for DURATION s."""
    from sim.guidance import loop
    from sim.guidance.world_adapter import autopilot_for, gains_for
    from sim.world import VehicleSpec, WorldSpec, build_world
    from sim.world.seabed import SeabedSpec

    w = build_world(
        WorldSpec(
            seabed=SeabedSpec(kind="flat", size_xy=(160.0, 160.0), resolution=2.0, depth=20.0),
            vehicles=(VehicleSpec("alister9", position=(0.0, 0.0, -8.0)),),
        )
    )
    g = gains_for(w, "alister9")
    ap = autopilot_for(
        w, "alister9", loop([(0, 0), (40, 0), (40, 25), (0, 25)], speed=g.cruise_speed, depth=8.0)
    )
    h = w.vehicles["alister9"]
    n = round(DT / w.timestep)
    states = []
    while w.time < SETTLE + DURATION - 1e-9:
        s = h.state()
        if s.t >= SETTLE - 1e-9:
            states.append(s)
        h.apply_wrench_demand(ap.update(s, DT))
        w.step(n)
    states.append(h.state())
    yaw = np.unwrap([s.euler[2] for s in states])
    assert abs(yaw[-1] - yaw[0]) > math.radians(120)  # the run does turn
    return states


def _pose(s) -> np.ndarray:
    return np.array([s.position[0], s.position[1], s.euler[2]])


def _compose(x, P, d, Q):
    """SLAM predict: x ⊕ d and its first-order covariance, d independent of x."""
    c, s = math.cos(x[2]), math.sin(x[2])
    Fx = np.array([[1, 0, -s * d[0] - c * d[1]], [0, 1, c * d[0] - s * d[1]], [0, 0, 1]])
    Fu = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    xn = np.array([x[0] + c * d[0] - s * d[1], x[1] + s * d[0] + c * d[1], x[2] + d[2]])
    return xn, Fx @ P @ Fx.T + Fu @ Q @ Fu.T


def _wrap(a):
    return (a + math.pi) % (2 * math.pi) - math.pi


def _monte_carlo(
    states, heading_aiding: bool, n_runs: int, seed0: int = 0, cut_s=CUT_S, whole=False
):
    """Per run: the increment errors/covs (cut every ``cut_s``), the composed 60 s
    error/cov, and the final z-gyro bias error squared over its variance; with ``whole``
    also the whole run as one increment (error, cov) from a never-cut twin dead reckoner
    fed the same readings (what a suite cut only at the end reports)."""
    cut = round(cut_s / DT)
    inc_e, inc_c, acc_e, acc_c, bias_z, whole_e, whole_c = [], [], [], [], [], [], []
    for seed in range(seed0, seed0 + n_runs):
        suite = NavSuite(
            # consumer IMU preset; DVL pings as interval means (see module docstring)
            NavSuiteConfig(
                heading_aiding=heading_aiding,
                dvl=DVL_MEAN,
                ahrs=AHRS_WHITE,
                matched_odometry_covariance=False,
            ),
            np.random.default_rng(seed),
            t0=states[0].t,
            initial_velocity_body=states[0].velocity_body,
        )
        twin = (
            DeadReckoner(
                suite.dead_reckoner.config,
                t0=states[0].t,
                initial_velocity_body=states[0].velocity_body,
            )
            if whole
            else None
        )
        x, P = np.zeros(3), np.zeros((3, 3))
        start = states[0]
        for k, s in enumerate(states):
            r = suite.poll(s)
            if twin is not None:
                twin.add_all([*r.ahrs, *r.imu, *r.dvl])  # the order NavSuite.poll uses
            if k > 0 and k % cut == 0:
                inc = suite.odometry(s.t)
                e = inc.delta - true_increment(_pose(start), _pose(s))
                e[2] = _wrap(e[2])
                inc_e.append(e)
                inc_c.append(inc.cov)
                x, P = _compose(x, P, inc.delta, inc.cov)
                start = s
        e = x - true_increment(_pose(states[0]), _pose(states[-1]))
        e[2] = _wrap(e[2])
        acc_e.append(e)
        acc_c.append(P)
        dr = suite.dead_reckoner
        b_err = suite.imu.gyro_bias[2] - dr.gyro_bias
        bias_z.append(b_err**2 / dr.P[10, 10])  # residual z-gyro bias state
        if twin is not None:
            inc = twin.increment(states[-1].t)
            e = inc.delta - true_increment(_pose(states[0]), _pose(states[-1]))
            e[2] = _wrap(e[2])
            whole_e.append(e)
            whole_c.append(inc.cov)
    return (
        np.array(inc_e),
        np.array(inc_c),
        np.array(acc_e),
        np.array(acc_c),
        np.array(bias_z),
        np.array(whole_e),
        np.array(whole_c),
    )


def _nees_sum(errs, covs):
    return float(np.einsum("ni,nij,nj->n", errs, np.linalg.inv(covs), errs).sum())


def _chi2_bounds(dof, p=1e-3):
    return stats.chi2.ppf(p / 2, dof), stats.chi2.ppf(1 - p / 2, dof)


@pytest.fixture(scope="module")
def mc_aided(flown_states):
    return _monte_carlo(flown_states, heading_aiding=True, n_runs=N_RUNS, whole=True)


def test_consumer_imu_aided_5s_increments_nees_inside_chi2(mc_aided):
    """Σ NEES of all 5 s increments (12 per run x 40 runs) is χ²(3N), 99.9 % two-sided."""
    errs, covs = mc_aided[:2]
    lo, hi = _chi2_bounds(3 * len(errs))
    nees = _nees_sum(errs, covs)
    assert lo < nees < hi, (nees / len(errs), lo / len(errs), hi / len(errs))


def test_consumer_imu_aided_60s_composed_pose_is_not_overconfident(mc_aided):
    """The 60 s pose composed from the 5 s increments as SLAM composes them (independent
    increments): Σ NEES over the runs below the χ²(3R) 99.95 % point (no
    over-confidence, the reported bug), but not absurdly conservative (mean NEES > 1 of
    the 3 expected). It is conservative by design: the compass bounds the absolute
    heading error, so consecutive increments' heading errors are negatively correlated
    and adding their variances over-counts (exact joint statistics: next test)."""
    errs, covs = mc_aided[2:4]
    _, hi = _chi2_bounds(3 * len(errs))
    nees = _nees_sum(errs, covs)
    assert len(errs) < nees < hi, (nees / len(errs), hi / len(errs))
    assert np.sqrt(np.mean(errs[:, 2] ** 2)) < math.radians(3.0)


def test_consumer_imu_aided_60s_increment_nees_inside_chi2(mc_aided):
    """The same 60 s cut as one increment (the dead reckoner's own covariance, which
    carries every correlation): Σ NEES over the runs is χ²(3R), 99.9 % two-sided."""
    errs, covs = mc_aided[5:7]
    assert len(errs) == N_RUNS
    lo, hi = _chi2_bounds(3 * len(errs))
    nees = _nees_sum(errs, covs)
    assert lo < nees < hi, (nees / len(errs), lo / len(errs), hi / len(errs))


def test_consumer_imu_gyro_bias_estimate_is_consistent(mc_aided):
    """The compass-aided gyro-bias estimate after 60 s against the IMU's true (simulated)
    z bias: Σ (b − b̂)² / P_bb over the runs is χ²(R), 99.9 % two-sided."""
    z = mc_aided[4]
    lo, hi = _chi2_bounds(len(z))
    assert lo < z.sum() < hi, (z.mean(), lo / len(z), hi / len(z))


def test_consumer_imu_gyro_only_heading_is_overconfident_when_composed(flown_states):
    """The reported bug: without the compass, the consumer gyro's turn-on bias drifts the
    heading ~10–20° a minute, an error common to all increments; composing 0.5 s
    increments as independent (n σ² instead of n² σ²) gives a 60 s NEES far above the
    χ² bound (the runner cuts at every 0.05 s tick: worse still)."""
    _, _, errs, covs, *_ = _monte_carlo(flown_states, heading_aiding=False, n_runs=10, cut_s=0.5)
    _, hi = _chi2_bounds(3 * len(errs))
    assert _nees_sum(errs, covs) > 3 * hi
    assert np.sqrt(np.mean(errs[:, 2] ** 2)) > math.radians(5.0)


def test_compass_fusion_static_heading_is_the_mean_of_n_samples():
    """Noise-free gyro, no bias, static vehicle: n compass samples of std σ give the
    heading variance σ²/n (the mean of n independent samples), and the fused heading is
    that mean (the Kalman filter with no process noise is recursive averaging)."""
    sigma, n = math.radians(2.0), 25
    dr = DeadReckoner(
        DeadReckoningConfig(dvl_velocity_std=0.01, gyro_sample_std=0.0, ahrs_yaw_std=sigma)
    )
    rng = np.random.default_rng(5)
    yaws = 0.7 + sigma * rng.standard_normal(n)
    for k, y in enumerate(yaws):
        t = 0.1 * k
        dr.add(IMUMeasurement(t=t, gyro=np.zeros(3), specific_force=np.zeros(3)))
        dr.add(AHRSMeasurement(t=t, roll=0.0, pitch=0.0, yaw=float(y)))
    h = np.zeros(dr.P.shape[0])
    h[2] = 1.0  # absolute heading error e_psi
    assert float(h @ dr.P @ h) == pytest.approx(sigma**2 / n, rel=1e-9)
    assert dr.heading == pytest.approx(yaws.mean(), abs=1e-12)


def test_heading_aiding_config_rejects_negative_std():
    with pytest.raises(ValueError, match="ahrs_yaw_std"):
        DeadReckoningConfig(dvl_velocity_std=0.01, gyro_sample_std=0.0, ahrs_yaw_std=-1.0)


def test_heading_aiding_auto_rule_aids_consumer_not_tactical():
    """Default (None): aid when turn-on bias x 60 s exceeds the AHRS yaw std — consumer
    MEMS 5e-3 rad/s x 60 s = 17° > 1°: aided; tactical FOG 2.4e-7 x 60 s ≈ 0.001° < 1°:
    gyro only. Explicit True/False win."""
    assert NavSuiteConfig().aided
    assert not NavSuiteConfig(imu=IMUConfig.preset("tactical")).aided
    assert NavSuiteConfig(imu=IMUConfig.preset("tactical"), heading_aiding=True).aided
    assert not NavSuiteConfig(heading_aiding=False).aided
    gyrocompass = AHRSConfig.preset("gyrocompass", yaw_noise_std=0.45)  # a 26° "compass"
    assert not NavSuiteConfig(ahrs=gyrocompass).aided
    with pytest.raises(ValueError, match="heading_aiding"):
        NavSuiteConfig(heading_aiding="yes")

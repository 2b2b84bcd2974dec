"""NavBatch (sim.navigation.batch) against N NavSuite, the second implementation: the same
generators and states give the same readings (bit for bit where the arithmetic is the
same operations: DVL lock, depth, roll/pitch noise; to rounding elsewhere) and the same
dead-reckoned increments to rounding, on turning, pitching trajectories that leave and
regain the DVL's lock window; batchable configurations only (errors name the field)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim.frames import wxyz_from_euler
from sim.navigation import (
    AHRSConfig,
    DepthConfig,
    DVLConfig,
    IMUConfig,
    NavSuite,
    NavSuiteConfig,
)
from sim.navigation.batch import NavBatch
from sim.state import VehicleState


def _trajectory(seed: int, steps: int, dt: float = 0.1):
    """Smooth random motion: states (t accumulated as MuJoCo accumulates it) with yaw
    turns, small roll/pitch, surge 0.5-2 m/s, altitude sweeping through 0.3-100 m."""
    rng = np.random.default_rng(seed)
    t, yaw, x, y = 0.0, rng.uniform(-np.pi, np.pi), 0.0, 0.0
    f = rng.uniform(0.02, 0.2, 4)
    out = []
    for k in range(steps):
        r = 0.3 * math.sin(f[0] * t)
        roll, pitch = 0.05 * math.sin(f[1] * t), 0.08 * math.sin(f[2] * t)
        u = 1.2 + 0.7 * math.sin(f[3] * t)
        alt = 50.0 + 50.0 * math.cos(0.05 * t + seed)  # 0-100 m: in and out of lock
        out.append(
            VehicleState(
                t=t,
                position=np.array([x, y, -10.0 - 3.0 * math.sin(0.1 * t)]),
                quat_wxyz=wxyz_from_euler(roll, pitch, yaw),
                velocity_body=np.array([u, 0.05 * r, -0.02]),
                angular_velocity_body=np.array([0.01, 0.02, r]),
                acceleration_body=np.zeros(3),
                water_velocity_world=np.zeros(3),
                altitude=alt if k % 37 else float("nan"),
            )
        )
        yaw += r * dt
        x += u * math.cos(yaw) * dt
        y += u * math.sin(yaw) * dt
        for _ in range(2):  # two physics steps of 0.05 s, as the envs accumulate d.time
            t += dt / 2
    return out


CONFIGS = {
    "env-tactical": NavSuiteConfig(imu=IMUConfig.preset("tactical")),
    "consumer-gyro-only": NavSuiteConfig(heading_aiding=False),
    "point-gyro-no-ahrs-bar30": NavSuiteConfig(
        imu=IMUConfig.preset("tactical", gyro_averaged=False, rate_hz=7.0),
        ahrs=None,
        depth=DepthConfig.preset("bar30"),
        dvl=DVLConfig.preset("a50", rate_hz=3.0, dropout_prob=0.3),
    ),
}


@pytest.mark.parametrize("name", list(CONFIGS))
def test_readings_and_increments_equal_nav_suites(name):
    cfg = CONFIGS[name]
    n, steps = 3, 400
    trajs = [_trajectory(s, steps) for s in range(n)]
    seeds = [11, 12, 13]
    suites = [NavSuite(cfg, np.random.default_rng(s), t0=0.0) for s in seeds]
    batch = NavBatch(cfg, n, block=7)  # a small block: many refills on the way
    for i, s in enumerate(seeds):
        batch.reset(i, np.random.default_rng(s), 0.0)
    active = np.ones(n, bool)
    counts = np.zeros(5, int)
    for k in range(steps):
        sts = [tr[k] for tr in trajs]
        t = np.array([s.t for s in sts])
        batch.poll(
            active, t,
            np.array([s.quat_wxyz for s in sts]),
            np.array([s.velocity_body for s in sts]),
            np.array([s.angular_velocity_body for s in sts]),
            np.array([s.depth for s in sts]),
            np.array([s.altitude for s in sts]),
        )  # fmt: skip
        rep = batch.reported.copy()
        out = batch.out.copy()
        delta = batch.odometry(active, t).copy() if k else None
        for i, (nav, st) in enumerate(zip(suites, sts)):
            r = nav.poll(st)
            assert rep[i, 0] == bool(r.imu) and rep[i, 1] == bool(r.dvl)
            assert rep[i, 3] == bool(r.depth) and rep[i, 4] == bool(r.ahrs)
            if r.imu:
                np.testing.assert_allclose(out[i, 0:3], r.imu[-1].gyro, rtol=1e-9, atol=1e-15)
            if r.dvl:
                assert rep[i, 2] == r.dvl[-1].valid
                assert out[i, 6] == r.dvl[-1].altitude or math.isnan(r.dvl[-1].altitude)
                if r.dvl[-1].valid:
                    np.testing.assert_allclose(
                        out[i, 3:6], r.dvl[-1].velocity_body, rtol=1e-13, atol=1e-15
                    )
            if r.depth:
                assert out[i, 7] == r.depth[-1].depth
            if r.ahrs:
                assert (out[i, 8], out[i, 9]) == pytest.approx(
                    (r.ahrs[-1].roll, r.ahrs[-1].pitch), rel=1e-13, abs=1e-16
                )
            counts += [
                bool(r.imu),
                bool(r.dvl),
                bool(r.dvl and r.dvl[-1].valid),
                bool(r.depth),
                bool(r.ahrs),
            ]
            if k:
                d = nav.odometry(st.t).delta
                np.testing.assert_allclose(delta[i], d, rtol=1e-9, atol=1e-13)
    # every branch was taken: DVL pings with and without lock
    assert counts[1] > counts[2] > 0 and counts[0] > 0 and counts[3] > 0


def test_inactive_vehicles_are_left_alone():
    """A vehicle masked out of a tick keeps its state: polled later it matches a suite
    that skipped the same ticks (NavSensor's catch-up schedule)."""
    cfg = CONFIGS["env-tactical"]
    tr = _trajectory(4, 60)
    nav = NavSuite(cfg, np.random.default_rng(3))
    batch = NavBatch(cfg, 2)
    batch.reset(0, np.random.default_rng(3))
    batch.reset(1, np.random.default_rng(99))
    for k, st in enumerate(tr):
        act = np.array([k % 5 != 2, True])
        args = [
            np.array([a, a]) for a in (st.quat_wxyz, st.velocity_body, st.angular_velocity_body)
        ]
        t = np.array([st.t, st.t])
        batch.poll(act, t, *args, np.array([st.depth] * 2), np.array([st.altitude] * 2))
        if act[0]:
            r = nav.poll(st)
            if r.imu:
                np.testing.assert_allclose(batch.out[0, :3], r.imu[-1].gyro, rtol=1e-9)
            np.testing.assert_allclose(
                batch.odometry(act, t)[0], nav.odometry(st.t).delta, rtol=1e-9, atol=1e-13
            )


@pytest.mark.parametrize(
    "cfg, field",
    [
        (NavSuiteConfig(), "heading_aiding"),
        (NavSuiteConfig(imu=IMUConfig.preset("tactical", delay_s=0.01)), "imu.delay_s"),
        (
            NavSuiteConfig(imu=IMUConfig.preset("tactical"), dvl=DVLConfig(averaged=True)),
            "dvl.averaged",
        ),
        (
            NavSuiteConfig(imu=IMUConfig.preset("tactical"), ahrs=AHRSConfig(delay_s=0.2)),
            "ahrs.delay_s",
        ),
    ],
)
def test_unbatchable_configs_raise_naming_the_field(cfg, field):
    with pytest.raises(ValueError, match=field.replace(".", r"\.")):
        NavBatch(cfg, 2)
    with pytest.raises(ValueError, match="n = 0"):
        NavBatch(CONFIGS["env-tactical"], 0)

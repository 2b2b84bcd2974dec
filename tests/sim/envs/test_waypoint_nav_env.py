"""undersea/WaypointNav-v0: gymnasium's own checker, vectorization, determinism, bad input."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import sim.envs  # noqa: F401  (registers the ids)

ID = "undersea/WaypointNav-v0"


@pytest.fixture(scope="module")
def env():
    e = gym.make(ID, render_mode="rgb_array")
    yield e
    e.close()


@pytest.mark.filterwarnings("ignore:.*Box observation space.*infinity")
def test_check_env_passes(env):
    """gymnasium's env_checker: spaces, seeding, reset/step API, render."""
    check_env(env.unwrapped)


def test_same_seed_same_actions_same_observations():
    """Two envs, same seed and actions -> identical observation sequences; another seed differs."""

    def roll(seed):
        e = gym.make(ID)
        obs, _ = e.reset(seed=seed)
        out = [obs]
        rng = np.random.default_rng(0)
        for _ in range(30):
            obs, *_ = e.step(rng.uniform(-1, 1, e.action_space.shape).astype(np.float32))
            out.append(obs)
        e.close()
        return np.array(out)

    a, b, c = roll(3), roll(3), roll(4)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)


def test_nan_action_rejected_and_out_of_range_clipped(env):
    """NaN/inf never reach the physics (ValueError, state unchanged); 5.0 is clipped to 1."""
    env.reset(seed=1)
    u = env.unwrapped
    t0 = u.world.time
    with pytest.raises(ValueError, match="finite"):
        env.step(np.array([np.nan, 0, 0], np.float32))
    with pytest.raises(ValueError, match="finite"):
        env.step(np.array([np.inf, 0, 0], np.float32))
    assert u.world.time == t0
    _, _, _, _, info = env.step(np.array([5.0, 0, 0], np.float32))
    assert info["action_clipped"] and np.all(np.isfinite(info["true_position"]))
    assert np.array_equal(u._last_u, [1.0, 0.0, 0.0])


def test_forward_thrust_moves_the_vehicle_forward():
    """Physical sanity: full stern thrust for 10 s moves the AUV along its heading
    (the dead-reckoned pose follows the truth within a few metres)."""
    e = gym.make(ID)
    _, info0 = e.reset(seed=2)
    yaw = info0["true_yaw"]
    for _ in range(100):
        _, _, term, _, info = e.step(np.array([1.0, 0.0, 0.0], np.float32))
        if term:
            break
    d = info["true_position"][:2] - info0["true_position"][:2]
    assert d @ np.array([np.cos(yaw), np.sin(yaw)]) > 5.0
    assert info["nav_position_error_m"] < 3.0
    e.close()


def test_render_rgb_array_top_down(env):
    env.reset(seed=0)
    img = env.render()
    assert img.shape == (480, 480, 3) and img.dtype == np.uint8 and img.std() > 1


def test_async_vector_env_runs():
    """gymnasium.make_vec(..., vectorization_mode='async') steps 2 envs in subprocesses."""
    venv = gym.make_vec(ID, num_envs=2, vectorization_mode="async", nav_sensors=False)
    try:
        obs, _ = venv.reset(seed=[1, 2])
        assert obs.shape == (2, 17)
        for _ in range(3):
            obs, rew, _, _, _ = venv.step(venv.action_space.sample())
        assert obs.shape == (2, 17) and np.all(np.isfinite(obs)) and rew.shape == (2,)
    finally:
        venv.close()


def test_unknown_vehicle_rejected():
    with pytest.raises(ValueError, match="alister9"):
        gym.make(ID, vehicle="nautilus")


def test_records_rerun(tmp_path):
    """record_path writes a recording with the vehicle transform at every step."""
    from sim.viz.rerun_log import read_recording

    p = tmp_path / "wp.rrd"
    e = gym.make(ID, record_path=str(p), nav_sensors=False)
    e.reset(seed=0)
    for _ in range(5):
        e.step(e.action_space.sample())
    e.close()
    ents = read_recording(p)
    assert ents["/world/alister9"].rows == 5 and ents["/world/seabed"].static
    assert ents["/world/alister9/mesh"].static

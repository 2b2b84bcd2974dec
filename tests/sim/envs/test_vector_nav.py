"""Batched WaypointNav (sim.envs.vector_nav) against N single WaypointNavEnv with the same
seeds and actions (the second implementation): same observations, rewards, ends and
autoresets."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from vector_env_pairs import batch_and_singles

import sim.envs  # noqa: F401


def _pair(seeds, max_steps, nav):
    venv, ov, singles, os_ = batch_and_singles("undersea/WaypointNav-v0", seeds, max_steps, nav)
    np.testing.assert_array_equal(ov, np.array(os_))
    return venv, singles


@pytest.mark.parametrize("nav", [False, True], ids=["ideal-nav", "nav-sensors"])
def test_batch_equals_single_envs_through_truncation_and_autoreset(nav):
    """3 envs, episodes truncated at 15 steps, 40 steps: true positions equal to the single
    envs' bit for bit, observations to float32 rounding (the batch rotates velocities with
    its own quaternion formula), rewards to 1e-12, the same ends; the step after an end
    returns the reset observation (gymnasium's NEXT_STEP autoreset, the single env reset
    without a seed)."""
    n, seeds = 3, [5, 6, 7]
    venv, singles = _pair(seeds, 15, nav)
    rng = np.random.default_rng(1)
    done = np.zeros(n, bool)
    resets = 0
    for _ in range(40):
        a = rng.uniform(-1.2, 1.2, venv.action_space.shape).astype(np.float32)
        ov, rv, tv, trv, info = venv.step(a)
        for i, e in enumerate(singles):
            if done[i]:
                o, _ = e.reset()
                r, te, tr = 0.0, False, False
                resets += 1
            else:
                o, r, te, tr, inf = e.step(a[i])
                assert info["action_clipped"][i] == inf["action_clipped"]
                np.testing.assert_allclose(info["true_position"][i], inf["true_position"], atol=0)
            np.testing.assert_allclose(ov[i], o, rtol=1e-6, atol=1e-12)
            assert rv[i] == pytest.approx(r, abs=1e-12)
            assert (tv[i], trv[i]) == (te, tr)
            done[i] = te or tr
    assert resets >= n  # every env went through an autoreset


def test_collision_terminates_like_the_single_env():
    """Full thrust, elevator hard over: the batch ends the episodes at the same steps as
    single envs, the collisions with the -50 penalty."""
    n, seeds = 2, [3, 4]
    venv, singles = _pair(seeds, 3000, False)
    a = np.tile(np.array([1.0, 0.0, -1.0], np.float32), (n, 1))  # thrust, elevator down
    for _ in range(600):
        ov, _, tv, _, info = venv.step(a)
        outs = [e.step(a[i]) for i, e in enumerate(singles)]
        np.testing.assert_allclose(ov, np.array([o[0] for o in outs]), rtol=1e-6, atol=1e-12)
        assert list(tv) == [o[2] for o in outs]
        if tv.any():
            break
    assert tv.any() and (info["collided"][tv] | (info["waypoint_index"][tv] == 3)).all()
    assert (info["reward_collision"][info["collided"]] == -50.0).all()


def test_bad_arguments_and_actions_raise_naming_the_field():
    with pytest.raises(ValueError, match="num_envs"):
        gym.make_vec("undersea/WaypointNav-v0", num_envs=0, vectorization_mode="vector_entry_point")
    venv = gym.make_vec(
        "undersea/WaypointNav-v0", num_envs=2, vectorization_mode="vector_entry_point"
    )
    venv.reset(seed=0)
    with pytest.raises(ValueError, match="finite"):
        venv.step(np.full((2, 3), np.nan))
    with pytest.raises(ValueError, match="shape"):
        venv.step(np.zeros((3, 3)))

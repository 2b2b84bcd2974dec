"""Batched SonarSurvey (sim.envs.vector_sonar) against N single SonarSurveyEnv with the
same seeds and actions (the second implementation): same observations (nav and
waterfall), rewards, coverage, ends and autoresets."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from vector_env_pairs import batch_and_singles

import sim.envs  # noqa: F401

pytestmark = pytest.mark.filterwarnings("ignore:.*Box observation space.*infinity")


def _pair(seeds, max_steps, nav):
    venv, ov, singles, os_ = batch_and_singles("undersea/SonarSurvey-v0", seeds, max_steps, nav)
    for i, o in enumerate(os_):
        np.testing.assert_array_equal(ov["nav"][i], o["nav"])
        np.testing.assert_array_equal(ov["waterfall"][i], o["waterfall"])
    return venv, singles


@pytest.mark.parametrize("nav", [False, True], ids=["ideal-nav", "nav-sensors"])
def test_batch_equals_single_envs_through_truncation_and_autoreset(nav):
    """3 envs, episodes truncated at 8 steps, 20 steps: true positions equal to the single
    envs' bit for bit, waterfalls (the pings) and coverage equal, nav observations to
    float32 rounding, rewards to 1e-12, the same ends; the step after an end returns the
    reset observation (gymnasium's NEXT_STEP autoreset, the single env reset without a
    seed)."""
    n, seeds = 3, [5, 6, 7]
    venv, singles = _pair(seeds, 8, nav)
    rng = np.random.default_rng(1)
    done = np.zeros(n, bool)
    resets = 0
    for _ in range(20):
        a = rng.uniform(-1.2, 1.2, venv.action_space.shape).astype(np.float32)
        a[:, 0] = np.abs(a[:, 0])  # forward: the pings sweep new seabed
        ov, rv, tv, trv, info = venv.step(a)
        for i, e in enumerate(singles):
            if done[i]:
                o, inf = e.reset()
                r, te, tr = 0.0, False, False
                resets += 1
            else:
                o, r, te, tr, inf = e.step(a[i])
                assert info["action_clipped"][i] == inf["action_clipped"]
                np.testing.assert_array_equal(info["true_position"][i], inf["true_position"])
            assert info["coverage"][i] == inf["coverage"] or done[i]
            np.testing.assert_array_equal(ov["waterfall"][i], o["waterfall"])
            np.testing.assert_allclose(ov["nav"][i], o["nav"], rtol=1e-6, atol=1e-12)
            assert rv[i] == pytest.approx(r, abs=1e-12)
            assert (tv[i], trv[i]) == (te, tr)
            done[i] = te or tr
    assert resets >= n  # every env went through an autoreset
    assert (ov["waterfall"][:, -1].std(axis=1) > 0).all()  # the sonar pinged


def test_coverage_reward_counts_new_cells():
    """Flying straight: the summed coverage reward of each env equals its covered area /
    100 m² (cell 2 m: 0.04 per cell), coverage grows, and bad actions name the problem."""
    venv = gym.make_vec(
        "undersea/SonarSurvey-v0", num_envs=2, vectorization_mode="vector_entry_point"
    )
    venv.reset(seed=3)
    total = np.zeros(2)
    a = np.tile(np.array([1.0, 0.0, 0.0], np.float32), (2, 1))
    for _ in range(30):
        _, _, _, _, info = venv.step(a)
        total += info["reward_coverage"]
    cells = venv.unwrapped.covered[0].size
    np.testing.assert_allclose(total, info["coverage"] * cells * 4.0 / 100.0)
    assert (info["coverage"] > 0.01).all()
    with pytest.raises(ValueError, match="finite"):
        venv.step(np.full((2, 3), np.nan))
    with pytest.raises(ValueError, match="shape"):
        venv.step(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="blueview_p900_90"):  # a forward-looking preset
        gym.make_vec(
            "undersea/SonarSurvey-v0", num_envs=2, vectorization_mode="vector_entry_point",
            sonar="blueview_p900_90",
        )  # fmt: skip

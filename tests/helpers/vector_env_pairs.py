"""A batched env and N single envs of the same id, reset with the same seeds: the
second implementation the vector-env tests compare the batch against."""

from __future__ import annotations

import gymnasium as gym

import sim.envs  # noqa: F401  (registers the undersea/* ids)


def batch_and_singles(env_id, seeds, max_steps, nav):
    """``gym.make_vec(env_id, len(seeds), vector_entry_point)`` and ``len(seeds)``
    ``gym.make(env_id)``, both with ``nav_sensors=nav`` and ``max_episode_steps``, each
    reset with ``seeds``; returns (venv, its reset observation, singles, their reset
    observations)."""
    venv = gym.make_vec(
        env_id,
        num_envs=len(seeds),
        vectorization_mode="vector_entry_point",
        nav_sensors=nav,
        max_episode_steps=max_steps,
    )
    singles = [gym.make(env_id, nav_sensors=nav, max_episode_steps=max_steps) for _ in seeds]
    ov, _ = venv.reset(seed=list(seeds))
    os_ = [e.reset(seed=s)[0] for e, s in zip(singles, seeds)]
    return venv, ov, singles, os_

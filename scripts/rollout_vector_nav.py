"""PPO-style rollout collection on a batched undersea env, with a random policy.

Collects ``--horizon`` steps from ``--num-envs`` vehicles into the (T, N, ...) buffers a
PPO update consumes (observations, actions, log-probabilities of a Gaussian policy,
rewards, dones, values), then computes GAE advantages and returns — everything but the
network. Replace ``policy`` with a trained actor-critic.

    python scripts/rollout_vector_nav.py --num-envs 64 --horizon 128 [--nav-sensors]
    python scripts/rollout_vector_nav.py --env SonarSurvey-v0 --num-envs 16 --horizon 32

(SonarSurvey-v0: a dict observation, nav (N, 13) and waterfall (N, 32, 64), buffered per
key.)
"""

from __future__ import annotations

import argparse
import time

import gymnasium as gym
import numpy as np

import sim.envs  # noqa: F401  (registers the ids and the vector entry point)


def policy(obs, rng: np.random.Generator, std: float = 0.5):
    """A random Gaussian policy: actions (N, k), their log-probabilities (N,), values (N,)."""
    n = (obs["nav"] if isinstance(obs, dict) else obs).shape[0]
    mean = np.zeros((n, 3))
    act = mean + std * rng.standard_normal((n, 3))
    logp = -0.5 * np.sum(((act - mean) / std) ** 2 + np.log(2 * np.pi * std**2), axis=1)
    return act.astype(np.float32), logp, np.zeros(n)


def gae(rewards, values, dones, last_value, gamma=0.99, lam=0.95):
    """Generalized advantage estimates (T, N) and returns (T, N) (Schulman et al. 2016)."""
    T = rewards.shape[0]
    adv = np.zeros_like(rewards)
    last = np.zeros(rewards.shape[1])
    for t in reversed(range(T)):
        nxt = last_value if t == T - 1 else values[t + 1]
        nonterminal = 1.0 - dones[t]
        delta = rewards[t] + gamma * nxt * nonterminal - values[t]
        last = delta + gamma * lam * nonterminal * last
        adv[t] = last
    return adv, adv + values


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--env", default="WaypointNav-v0", choices=("WaypointNav-v0", "SonarSurvey-v0"))
    p.add_argument("--num-envs", type=int, default=64)
    p.add_argument("--horizon", type=int, default=128)
    p.add_argument("--iterations", type=int, default=2)
    p.add_argument("--nav-sensors", action="store_true", help="nav-sensor observations")
    p.add_argument("--seed", type=int, default=0)
    a = p.parse_args(argv)
    venv = gym.make_vec(
        f"undersea/{a.env}",
        num_envs=a.num_envs,
        vectorization_mode="vector_entry_point",
        nav_sensors=a.nav_sensors,
    )
    rng = np.random.default_rng(a.seed)
    obs, _ = venv.reset(seed=a.seed)
    T, N = a.horizon, a.num_envs
    keys = list(obs) if isinstance(obs, dict) else [None]
    buf_obs = {
        k: np.zeros((T, *(obs[k] if k is not None else obs).shape), np.float32) for k in keys
    }
    buf_act = np.zeros((T, N, 3), np.float32)
    buf = {k: np.zeros((T, N)) for k in ("logp", "reward", "done", "value")}
    for it in range(a.iterations):
        t0 = time.perf_counter()
        for t in range(T):
            act, logp, value = policy(obs, rng)
            for k in keys:
                buf_obs[k][t] = obs[k] if k is not None else obs
            buf_act[t] = act
            obs, reward, term, trunc, _ = venv.step(act)
            buf["logp"][t], buf["value"][t] = logp, value
            buf["reward"][t], buf["done"][t] = reward, term | trunc
        dt = time.perf_counter() - t0
        adv, ret = gae(buf["reward"], buf["value"], buf["done"], policy(obs, rng)[2])
        print(
            f"iteration {it}: {T * N} steps in {dt:.2f} s ({T * N / dt:,.0f} steps/s), "
            f"mean reward {buf['reward'].mean():+.3f}, episodes ended {int(buf['done'].sum())}, "
            f"advantage std {adv.std():.3f}, mean return {ret.mean():+.3f}"
        )
    venv.close()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Flat DDPG under the engine's contract (``agents/base.py``): truncation bootstraps, steps after
the episode end are masked, learning rates decay per episode, ``evaluate`` returns a masked
trajectory, actions are mapped onto the env's box, runs are deterministic and vmap over seeds
equals single-seed runs."""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np
import probes
import pytest

from hiddpg.agents.base import EPISODE_KEYS
from hiddpg.agents.ddpg import make_ddpg
from hiddpg.configs import DDPGConfig, NoiseConfig

SMALL = dict(hidden=(32, 32), actor_lr=1e-3, critic_lr=1e-2, tau=0.05, batch_size=16,
             buffer_size=2000, learning_starts=20, noise=NoiseConfig(sigma=0.3),
             gamma=0.9, lr_decay=0.5, lr_decay_every=40)
EPISODES = 100


@functools.cache
def two_step():
    """TwoStep with horizon 3: the episode terminates after step 2, step 3 is masked."""
    env = probes.TwoStep()
    agent = make_ddpg(DDPGConfig(**SMALL), env)
    params = env.default_params(max_steps=3)
    train = probes.make_train(agent, params, EPISODES)
    state, metrics = train(jax.random.PRNGKey(0))
    return agent, params, train, state, metrics


def test_truncation_bootstraps():
    env = probes.TruncatedReward()
    cfg = DDPGConfig(**{**SMALL, "gamma": 0.5, "lr_decay": 1.0, "batch_size": 64,
                        "learning_starts": 64})
    agent = make_ddpg(cfg, env)
    state, metrics = probes.make_train(agent, env.default_params(), 600)(jax.random.PRNGKey(0))
    np.testing.assert_array_equal(metrics["length"], 1)  # truncated after one step
    assert probes.q_value(agent, state, 0.0) == pytest.approx(1 / (1 - 0.5), abs=0.1)


def test_end_is_terminal_stops_the_bootstrap_at_the_time_limit():
    """The paper's arm rule: the last step's target is its reward, time limit or not."""
    env = probes.TruncatedReward()
    cfg = DDPGConfig(**{**SMALL, "gamma": 0.5, "lr_decay": 1.0, "batch_size": 64,
                        "learning_starts": 64, "end_is_terminal": True})
    agent = make_ddpg(cfg, env)
    state, metrics = probes.make_train(agent, env.default_params(), 600)(jax.random.PRNGKey(0))
    np.testing.assert_array_equal(metrics["length"], 1)
    assert bool(np.all(np.asarray(state.buffer.data.terminated[: int(state.buffer.size)])))
    assert probes.q_value(agent, state, 0.0) == pytest.approx(1.0, abs=0.1)  # not 1 / (1 - γ)


def test_steps_after_the_episode_end_are_masked():
    _, _, _, state, m = two_step()
    starts = SMALL["learning_starts"]
    np.testing.assert_array_equal(m["length"], 2)
    np.testing.assert_array_equal(m["return"], 1.0)
    np.testing.assert_array_equal(m["env_return"], m["return"])
    np.testing.assert_array_equal(m["switches"], 0)
    np.testing.assert_array_equal(m["env_steps"], 2 * np.arange(1, EPISODES + 1))
    assert int(state.buffer.size) == 2 * EPISODES and int(state.episodes) == EPISODES
    updates = 2 * EPISODES - starts  # one per environment step once learning started
    assert int(state.block.critic_opt.count) == updates
    assert int(state.block.actor_opt.count) == updates
    first = starts // 2  # the first episode that learns
    np.testing.assert_array_equal(m["critic_loss"][:first], 0.0)
    np.testing.assert_array_equal(m["actor_loss"][:first], 0.0)
    assert (np.asarray(m["critic_loss"][first:]) > 0).all()


def test_learning_rates_decay_per_episode():
    agent, _, _, state, _ = two_step()
    lr_a, lr_c = agent.block.learning_rates(state.block)
    factor = 0.5 ** ((EPISODES - 1) // 40)  # the last episode's factor
    np.testing.assert_allclose(float(lr_a), 1e-3 * factor, rtol=1e-6)
    np.testing.assert_allclose(float(lr_c), 1e-2 * factor, rtol=1e-6)


def test_evaluate_returns_a_masked_trajectory():
    agent, params, _, state, _ = two_step()
    metrics, traj = jax.jit(agent.evaluate)(jax.random.PRNGKey(3), state, params)
    np.testing.assert_array_equal(traj["alive"], [1.0, 1.0, 0.0])
    np.testing.assert_array_equal(traj["reward"], [0.0, 1.0, 0.0])
    np.testing.assert_array_equal(traj["obs"][:, 0], [0.0, 1.0, 1.0])
    assert traj["action"].shape == (3, 1)
    assert float(metrics["return"]) == 1.0 and int(metrics["length"]) == 2
    assert set(EPISODE_KEYS) <= set(metrics)


def test_actions_are_mapped_onto_the_env_box():
    env = probes.ActionReward01()
    agent = make_ddpg(DDPGConfig(**{**SMALL, "learning_starts": 10_000}), env)
    np.testing.assert_array_equal(agent.to_env_action(jnp.array([-1.0, 0.0, 1.0])),
                                  [0.0, 0.5, 1.0])
    params = env.default_params(target=0.75)
    state, _ = probes.make_train(agent, params, 200)(jax.random.PRNGKey(0))
    a, r = np.asarray(state.buffer.data.action[:200, 0]), state.buffer.data.reward[:200]
    assert a.min() < -0.8 and a.max() > 0.8  # stored in the unit box, uniformly at random
    np.testing.assert_allclose(r, -(((a + 1) / 2 - 0.75) ** 2), rtol=1e-5, atol=1e-7)


def test_same_key_gives_bitwise_the_same_run():
    _, _, train, state0, metrics0 = two_step()
    state, metrics = train(jax.random.PRNGKey(0))
    for k in metrics:
        np.testing.assert_array_equal(metrics[k], metrics0[k])
    jax.tree_util.tree_map(np.testing.assert_array_equal, state, state0)
    _, other = train(jax.random.PRNGKey(1))
    assert not np.array_equal(other["critic_loss"], metrics["critic_loss"])


def test_vmap_over_seeds_equals_single_seed_runs():
    """Batched matmuls round differently in the last bit; over ~200 Adam steps that grows to
    ~1e-6 absolute in a few parameters, so parameters are compared at 1e-5, metrics at 1e-6."""
    _, _, train, _, _ = two_step()
    keys = jax.random.split(jax.random.PRNGKey(7), 3)
    states, metrics = jax.jit(jax.vmap(train))(keys)
    for i, key in enumerate(keys):
        state, m = train(key)
        for k in m:
            np.testing.assert_allclose(metrics[k][i], m[k], rtol=1e-6, atol=1e-6)
        got = jax.tree_util.tree_map(lambda x, i=i: x[i], states)
        jax.tree_util.tree_map(
            lambda a, b: np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-5), state, got)

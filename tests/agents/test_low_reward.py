"""The low level's intrinsic reward with the goal's other entries counted
(:class:`~hiddpg.configs.RestTerm`, ``agent.rest_term.weight``): the paper's goal is the state
``[gx, gy, 0, 0]``, so the velocities count towards it with weight ``w``; hindsight goals get
the same reward."""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from hiddpg.agents.transition import Transition
from hiddpg.presets import make_config
from hiddpg.runs import make_trainer
from hiddpg.train import seed_keys

BASE = ["agent.learning_starts=0", "agent.pretrain_episodes=0", "eval_every=2"]


@functools.cache
def _low_buffer(*sets: str) -> Transition:
    trainer = make_trainer(make_config("hi-ddpg", "PuckTrajectory1", "quick", [*BASE, *sets]))
    state, _, _ = trainer.run_chunk_seeds(trainer.init_seeds(seed_keys([0])), 2)
    buf = state.agent.low.buffer
    n = int(np.asarray(buf.size)[0])
    return jax.tree.map(lambda v: np.asarray(v)[0, :n], buf.data)


@pytest.mark.parametrize("w", [0.0, 0.3, 2.0])
def test_the_velocities_count_towards_the_goal_with_their_weight(w):
    low = _low_buffer(f"agent.rest_term.weight={w}")
    assert len(low.reward) == 60
    p_err = low.next_obs[:, :2] - low.context[:, :2]
    np.testing.assert_array_equal(low.context[:, 2:], 0.0)  # the goal is [gx, gy, 0, 0]
    expected = -np.sqrt(np.sum(p_err**2, -1) + w**2 * np.sum(low.next_obs[:, 2:] ** 2, -1))
    np.testing.assert_allclose(low.reward, expected, rtol=1e-5, atol=1e-6)
    moving = np.linalg.norm(low.next_obs[:, 2:], axis=-1) > 0.1
    assert moving.mean() > 0.5  # the check has velocities to count


def test_hindsight_goals_get_the_same_reward():
    from hiddpg.agents.hi_ddpg import make_hiddpg
    from hiddpg.envs import make as make_env

    cfg = make_config("hi-ddpg", "PuckTrajectory1", "quick",
                      [*BASE, "agent.rest_term.weight=0.5", "agent.low_hindsight.fraction=1.0"])
    env, _ = make_env("PuckTrajectory1")
    agent = make_hiddpg(cfg.agent, env)
    low = _low_buffer("agent.rest_term.weight=0.5", "agent.low_hindsight.fraction=1.0")
    reward = agent.low.hindsight.reward
    assert reward == agent.intrinsic_reward
    for i in (0, 17, 45):
        s2 = jnp.asarray(low.next_obs[i])
        goal = jnp.asarray(low.next_obs[min(i + 3, 59)]).at[2:].set(0.0)
        p_err = np.asarray(s2[:2] - goal[:2])
        expected = -np.sqrt(np.sum(p_err**2) + 0.25 * np.sum(np.asarray(s2[2:]) ** 2))
        np.testing.assert_allclose(float(reward(s2, goal)), expected, rtol=1e-5)


def test_the_weight_must_be_a_finite_non_negative_number():
    with pytest.raises(ValueError, match=r"RestTerm.weight=-1.0 must be a finite number >= 0"):
        make_config("hi-ddpg", "PuckTrajectory1", "quick", ["agent.rest_term.weight=-1"])

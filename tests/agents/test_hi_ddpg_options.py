"""The reference controller as HI-DDPG's low level (a diagnostic override), the time left as the
high level's input and holding a goal to the episode's end (:class:`HoldChoice`)."""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from hiddpg.experiments.overrides import reference_low_level, with_first_action
from hiddpg.presets import make_config
from hiddpg.runs import make_trainer
from hiddpg.train import Trainer, eval_keys, seed_keys

SEEDS = [0, 1, 2, 3]
BASE = ["agent.learning_starts=0", "agent.pretrain_episodes=0", "agent.high_learning_starts=1",
        "eval_every=2"]


@functools.cache
def _trainer(*sets: str):
    return make_trainer(make_config("hi-ddpg", "PuckTrajectory1", "quick", [*BASE, *sets]))


def _segments(buf) -> dict[str, np.ndarray]:
    n = int(np.asarray(buf.size)[0])
    names = {"s": "obs", "a": "action", "s2": "next_obs"}
    return {k: np.asarray(getattr(buf.data, f))[0, :n] for k, f in names.items()}


def test_the_reference_low_level_tracks_the_reference_plan_exactly_and_learns_nothing():
    config = make_config("hi-ddpg", "PuckTrajectory1", "quick", BASE)
    trainer = Trainer(config, override=reference_low_level)
    agent, params = trainer.agent, trainer.env_params
    state = trainer.init_seeds(seed_keys([0]))
    goal = agent.env.goal_space.unscale(jnp.asarray(params.goals[0]))
    first = jnp.concatenate([goal, agent.choice.duration_unit(jnp.asarray(30.0))[None]])
    one = jax.tree.map(lambda x: x[0], state.agent)
    probe = with_first_action(agent, first)
    metrics, _ = jax.jit(probe.evaluate)(eval_keys(0, [0])[0], one, params)
    assert abs(float(metrics["env_return"])) < 1e-3  # the reference trajectory, step by step
    assert float(metrics["switches"]) == 0
    before = jax.tree.map(np.asarray, state.agent.low.block.actor)  # the chunk donates state
    after, train_m, _ = trainer.run_chunk_seeds(state, 2)
    assert float(np.sum(train_m["low_critic_loss"])) == 0  # no low-level update
    assert float(np.sum(train_m["high_critic_loss"])) > 0
    same = jax.tree.map(lambda a, b: bool(np.all(a == np.asarray(b))), before,
                        after.agent.low.block.actor)
    assert all(jax.tree.leaves(same))


def test_environments_without_a_reference_controller_refuse_it():
    config = make_config("hi-ddpg", "ArmObstacle", "quick")
    with pytest.raises(ValueError, match="has no reference_controller"):
        Trainer(config, override=reference_low_level)
    ddpg = make_config("ddpg", "PuckTrajectory1", "quick")
    with pytest.raises(ValueError, match="replaces HI-DDPG's, not DDPGAgent's"):
        Trainer(ddpg, override=reference_low_level)


def test_the_high_level_sees_the_fraction_of_the_episode_left():
    trainer = _trainer("agent.choice=hold", "agent.choice.explore=0")
    agent = trainer.agent
    state, _, _ = trainer.run_chunk_seeds(trainer.init_seeds(seed_keys([0])), 2)
    seg = _segments(state.agent.high.buffer)
    assert seg["s"].shape[1] == agent.env.obs_dim + 1
    left, left2 = seg["s"][:, -1] * 30, seg["s2"][:, -1] * 30
    np.testing.assert_allclose(left[0], 30.0, atol=1e-5)  # the first segment starts the episode
    _, duration = jax.vmap(agent.decode)(jnp.asarray(seg["a"]))
    n = np.clip(np.round(np.asarray(duration)), 1, np.round(left))
    np.testing.assert_allclose(left - left2, n, atol=1e-4)
    starts = np.isclose(left, 30.0, atol=1e-4)
    ends = np.isclose(left2, 0.0, atol=1e-4)
    assert starts.sum() == ends.sum() == 2  # two episodes, each from 30 steps left down to 0


def test_hold_exploration_always_holds_the_first_goal_to_the_end():
    trainer = _trainer("agent.choice=hold", "agent.choice.explore=1.0")
    state, train_m, _ = trainer.run_chunk_seeds(trainer.init_seeds(seed_keys([0])), 2)
    np.testing.assert_array_equal(np.asarray(train_m["switches"]), 0)
    seg = _segments(state.agent.high.buffer)
    np.testing.assert_allclose(seg["s2"][:, -1], 0.0, atol=1e-6)


def _negated_critic(state):
    """The same agents with ``Q → -Q`` for the high level (the actor is unchanged)."""
    block = state.agent.high.block
    critic = jax.tree.map(lambda x: x, block.critic)
    out = dict(critic["params"]["out"])
    critic = {"params": dict(critic["params"], out={k: -v for k, v in out.items()})}
    high = state.agent.high.replace(block=block.replace(critic=critic))
    return state.replace(agent=state.agent.replace(high=high))


def _first_segment_lengths(traj) -> np.ndarray:
    later = np.asarray(traj["switch"])[:, 1:]
    return np.where(later.any(axis=1), np.argmax(later, axis=1) + 1, 30)


def test_hold_choice_holds_exactly_when_the_critic_prefers_it():
    """At the start state the critic compares the actor's (g, T) with (g, hold to the end);
    negating the critic flips every comparison, so each seed is tested on both sides."""
    trainer = _trainer("agent.choice=hold")
    agent = trainer.agent
    keys = eval_keys(0, SEEDS)
    state = trainer.init_seeds(seed_keys(SEEDS))
    q = jax.vmap(lambda h, o, a: agent.high.block.q(h.block.critic, o, a))
    act = jax.vmap(lambda h, o: agent.high.act(h, o, jnp.zeros((0,))))
    prefer = []
    for st in (state, _negated_critic(state)):
        _, traj = trainer.evaluate_seeds(st, keys)
        obs0 = jax.vmap(lambda o: agent.choice.inputs(o, jnp.asarray(30), 30))(traj["obs"][:, 0])
        own = act(st.agent.high, obs0)
        hold = own.at[:, -1].set(agent.choice.duration_unit(jnp.asarray(30.0)))
        prefers = np.asarray(q(st.agent.high, obs0, hold) > q(st.agent.high, obs0, own))
        _, own_t = jax.vmap(agent.decode)(own)  # the actor's own first duration
        own_len = np.clip(np.round(np.asarray(own_t)), 1, 30).astype(int)
        assert np.all(own_len < 30)  # the actor's own first duration is shorter
        np.testing.assert_array_equal(_first_segment_lengths(traj),
                                      np.where(prefers, 30, own_len))
        prefer.append(prefers)
    np.testing.assert_array_equal(prefer[0], ~prefer[1])

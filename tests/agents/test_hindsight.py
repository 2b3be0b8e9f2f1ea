"""Hindsight goals for the low level: relabelled goals come from later in the same episode,
rewards are recomputed for them, the fraction holds, and HI-DDPG stores what it needs."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from hiddpg.agents import buffer
from hiddpg.agents.hindsight import Hindsight
from hiddpg.agents.transition import Transition, example
from hiddpg.envs.base import GoalSpace
from hiddpg.presets import make_config
from hiddpg.runs import make_trainer
from hiddpg.train import seed_keys

SPACE = GoalSpace((0, 1), (-50.0, -50.0), (50.0, 50.0))
SET_GOAL = 100.0  # the goal "the high level set" in the hand-made buffers


def _reward(s2, g):
    return -jnp.linalg.norm(s2[:2] - g[:2])


def _buffer(episodes: list[int], capacity: int):
    """Episodes of the given lengths, written in order; ``s2`` at step k of episode e is
    ``(10 e + k + 1, -(10 e + k + 1))``; the time limit is 6 steps, so a length under 6 is an
    early end (a collision)."""
    buf = buffer.init(example(4, 2, 4, hindsight=True), capacity)
    for e, length in enumerate(episodes):
        for k in range(length):
            v = 10.0 * e + k + 1
            buf = buffer.add(buf, Transition(
                obs=jnp.zeros(4), context=jnp.array([SET_GOAL, 0, 0, 0]),
                action=jnp.full(2, 0.25), reward=-1.0, next_obs=jnp.array([v, -v, 0.0, 0.0]),
                terminated=False, episode=e, steps_left=5 - k))
    return buf


@pytest.mark.parametrize("episodes,capacity", [([6, 6, 6], 32), ([6, 3, 6, 6], 16)])
def test_relabelled_goals_are_reached_later_in_the_same_episode(episodes, capacity):
    buf = _buffer(episodes, capacity)
    tr = Hindsight(0.5, SPACE, 4, _reward).sample(buf, jax.random.PRNGKey(3), 4000)
    tr = jax.tree.map(np.asarray, tr)
    used = tr.context[:, 0] != SET_GOAL
    assert 0.46 < used.mean() < 0.54
    # kept transitions are untouched
    np.testing.assert_array_equal(tr.reward[~used], -1.0)
    # a relabelled goal is a later s2 of the same episode (episode e's values lie in 10e+1..)
    g, s2 = tr.context[used], tr.next_obs[used]
    offset = g[:, 0] - s2[:, 0]
    assert offset.min() == 0
    assert np.all(offset <= tr.steps_left[used])
    assert np.all((g[:, 0] - 1) // 10 == (s2[:, 0] - 1) // 10)
    np.testing.assert_array_equal(g[:, 1], -g[:, 0])  # both goal entries from the same state
    np.testing.assert_array_equal(g[:, 2:], 0.0)  # entries outside the goal space stay 0
    # the reward is recomputed for the new goal
    expected = -np.hypot(offset, offset)
    np.testing.assert_allclose(tr.reward[used], expected, rtol=1e-6)
    # every offset the episode allows is drawn
    assert set(np.unique(offset).astype(int)) == set(range(6))


def test_an_episode_cut_short_or_overwritten_falls_back_to_its_own_next_state():
    # episode 1 ends after 3 of 6 steps: offsets that would run past its end into episode 2
    # are replaced by offset 0
    buf = _buffer([6, 3, 6], 32)
    tr = jax.tree.map(np.asarray,
                      Hindsight(1.0, SPACE, 4, _reward).sample(buf, jax.random.PRNGKey(0), 4000))
    short = (tr.next_obs[:, 0] > 10) & (tr.next_obs[:, 0] < 20)
    assert np.all(tr.context[short, 0] < 20)
    last = tr.next_obs[:, 0] == 13  # episode 1's last step: only itself
    np.testing.assert_array_equal(tr.context[last, 0], 13.0)
    # the newest transition has nothing written after it
    newest = tr.next_obs[:, 0] == 26
    assert newest.any()
    np.testing.assert_array_equal(tr.context[newest, 0], 26.0)


def test_fraction_zero_is_the_plain_sample():
    buf = _buffer([6, 6], 16)
    key = jax.random.PRNGKey(5)
    plain = buffer.sample(buf, jax.random.split(key, 3)[0], 64)
    tr = Hindsight(0.0, SPACE, 4, _reward).sample(buf, key, 64)
    assert jax.tree.structure(tr) == jax.tree.structure(plain)
    for a, b in zip(jax.tree.leaves(tr), jax.tree.leaves(plain), strict=True):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))


def test_hi_ddpg_stores_the_episode_and_the_steps_left():
    sets = ["agent.learning_starts=0", "agent.pretrain_episodes=0", "eval_every=2",
            "agent.low_hindsight.fraction=0.8"]
    trainer = make_trainer(make_config("hi-ddpg", "PuckTrajectory1", "quick", sets))
    state, _, _ = trainer.run_chunk_seeds(trainer.init_seeds(seed_keys([0])), 2)
    buf = state.agent.low.buffer
    n = int(np.asarray(buf.size)[0])
    assert n == 60
    ep, left = np.asarray(buf.data.episode)[0, :n], np.asarray(buf.data.steps_left)[0, :n]
    np.testing.assert_array_equal(ep, np.repeat([0, 1], 30))
    np.testing.assert_array_equal(left, np.tile(np.arange(29, -1, -1), 2))


def test_the_fraction_must_be_a_probability():
    with pytest.raises(ValueError, match=r"GoalHindsight.fraction=1.5 must lie in \[0, 1\]"):
        make_config("hi-ddpg", "PuckTrajectory1", "quick", ["agent.low_hindsight.fraction=1.5"])


GOALS = ((1.5, 0.35), (-0.5, 1.0), (2.0, -1.5), (0.5, 2.0))


def _reach_errors(*sets: str, episodes: int = 200) -> np.ndarray:
    """Low-level pre-training only (random goals) on the puck for ``episodes``, 2 seeds; then
    each seed's low level holds each of :data:`GOALS` for 30 steps from the start state,
    noise-free: the final distances, (seeds, goals)."""
    cfg = make_config("hi-ddpg", "PuckTrajectory1", "quick",
                      [f"episodes={episodes}", f"eval_every={episodes}",
                       f"agent.pretrain_episodes={episodes}", *sets])
    trainer = make_trainer(cfg)
    state, _, _ = trainer.run_chunk_seeds(trainer.init_seeds(seed_keys([0, 1])), episodes)
    env, params, agent = trainer.env, trainer.env_params, trainer.agent

    def reach(low, goal):
        def step(x, _):
            return env.dynamics(x, agent.env_action(agent.low.act(low, x, goal)), params), None

        x, _ = jax.lax.scan(step, jnp.array([0.0, 0.0, 0.5, 0.5]), None, length=30)
        return jnp.linalg.norm(x[:2] - goal[:2])

    goals = env.goal_space.embed(jnp.asarray(GOALS, jnp.float32), env.obs_dim)
    per_seed = jax.vmap(lambda low: jax.vmap(lambda g: reach(low, g))(goals))
    return np.asarray(jax.jit(per_seed)(state.agent.low))


@pytest.mark.heavy
def test_hindsight_goals_teach_the_low_level_to_reach_much_sooner():
    """A learned outcome: after 200 episodes of random goals the low level with hindsight
    goals ends within about 0.3 of goals it was not trained on in particular (measured:
    mean 0.26; without: 1.1, the puck passing or falling short of its goal)."""
    plain = _reach_errors()
    hindsight = _reach_errors("agent.low_hindsight.fraction=0.5")
    assert hindsight.mean() < 0.4, hindsight
    assert plain.mean() > 2 * hindsight.mean(), (plain, hindsight)

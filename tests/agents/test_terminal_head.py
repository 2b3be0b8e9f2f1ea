"""The terminal head: a critic ``Q = Q_run + Q_term`` whose second head learns the rewards of
terminating steps (the arm's collision, -100) apart from the rest, so that a Huber loss on the
first keeps collisions at their full expected cost; and HI-DDPG's high level storing the pairs."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from hiddpg.agents.block import DDPGBlock
from hiddpg.presets import make_config
from hiddpg.runs import make_trainer
from hiddpg.train import seed_keys

OBS, ACT, B = 3, 2, 32


def _block(**kw):
    args = dict(obs_dim=OBS, action_dim=ACT, hidden=(32, 32), actor_lr=1e-3, critic_lr=1e-2,
                gamma=0.9, tau=0.1, terminal_head=True)
    return DDPGBlock(**{**args, **kw})


def _batch(seed=0):
    k = jax.random.split(jax.random.PRNGKey(seed), 5)
    return {"obs": jax.random.normal(k[0], (B, OBS)),
            "action": jax.random.uniform(k[1], (B, ACT), minval=-1, maxval=1),
            "reward": jax.random.normal(k[2], (B, 2)),
            "next_obs": jax.random.normal(k[3], (B, OBS)),
            "terminated": jax.random.bernoulli(k[4], 0.3, (B,))}


def test_q_is_the_sum_of_the_heads_and_each_head_bootstraps_on_its_own():
    block = _block()
    state = block.init(jax.random.PRNGKey(0))
    other = block.init(jax.random.PRNGKey(1))
    bump = lambda p: jax.tree.map(lambda x: 30.0 * x, p)  # noqa: E731 (non-trivial values)
    state = state.replace(target_actor=other.actor, target_critic=bump(other.critic))
    batch = _batch()
    heads = block.q_heads(state.target_critic, batch["next_obs"],
                          block.mu(state.target_actor, batch["next_obs"]))
    assert heads.shape == (B, 2) and float(jnp.abs(heads[:, 0] - heads[:, 1]).mean()) > 1e-3
    np.testing.assert_allclose(
        block.q(state.target_critic, batch["next_obs"], batch["action"]),
        block.q_heads(state.target_critic, batch["next_obs"], batch["action"]).sum(-1),
        rtol=1e-6)
    not_done = 1.0 - batch["terminated"].astype(jnp.float32)
    expected = batch["reward"] + 0.9 * not_done[:, None] * heads
    np.testing.assert_allclose(block.target(state, batch), expected, rtol=1e-6, atol=1e-6)
    with pytest.raises(ValueError, match="terminal_head takes no batch"):
        block.target(state, {**batch, "next_q": jnp.zeros(B)})


def _fit(block: DDPGBlock, reward: jax.Array) -> jax.Array:
    """The critic's heads after 2000 steps on one observation and action, every sample
    terminated (the targets are the rewards)."""
    batch = {"obs": jnp.zeros((B, OBS)), "action": jnp.zeros((B, ACT)), "reward": reward,
             "next_obs": jnp.zeros((B, OBS)), "terminated": jnp.ones((B,), bool)}
    s = block.init(jax.random.PRNGKey(0))
    s = jax.lax.fori_loop(0, 2000, lambda _, s: block.critic_update(s, batch)[0], s)
    return block.q_heads(s.critic, jnp.zeros(OBS), jnp.zeros(ACT))


def test_a_huber_run_head_keeps_the_collisions_expected_cost():
    """31 segments returning -1 and one that collides (-0.5 before the collision, -100 for it):
    with one head and δ = 1 the fit is about -1.03 (the collision nearly ignored); with the
    terminal head the run head is a Huber fit of the run rewards and the terminal head the mean
    terminal reward, -100/32, so Q is the mean return, about -4.1."""
    run = jnp.full((B,), -1.0).at[0].set(-0.5)
    term = jnp.zeros((B,)).at[0].set(-100.0)
    one = _fit(_block(terminal_head=False, huber_delta=1.0, critic_lr=3e-2), run + term)
    assert abs(float(one) - (-1.0 - 1.0 / (B - 1))) < 0.2, one
    q_run, q_term = _fit(_block(huber_delta=1.0, critic_lr=3e-2), jnp.stack([run, term], -1))
    assert abs(float(q_term) - (-100.0 / B)) < 0.1, q_term
    assert abs(float(q_run) - (-1.0)) < 0.05, q_run
    assert abs(float(q_run + q_term) - float(jnp.mean(run + term))) < 0.15


def _high_buffer(*sets: str):
    """D_H's rewards after 30 episodes of random goals on ArmObstacle with the obstacle grown
    to 0.131 m (random movements hit it), no learning."""
    sets = ["agent.learning_starts=100000", "agent.pretrain_episodes=0", "eval_every=30",
            "env.obstacle_diameter=0.131", *sets]
    trainer = make_trainer(make_config("hi-ddpg", "ArmObstacle", "quick", sets))
    state, _, _ = trainer.run_chunk_seeds(trainer.init_seeds(seed_keys([0])), 30)
    buf = state.agent.high.buffer
    return np.asarray(buf.data["r"])[0, : int(np.asarray(buf.size)[0])]


def test_high_level_stores_the_collision_apart_from_the_segment_return():
    plain = _high_buffer()
    pairs = _high_buffer("agent.high.terminal_head=true")
    assert pairs.shape == plain.shape + (2,)
    collided = pairs[:, 1] != 0
    assert collided.sum() >= 10 and (~collided).sum() >= 30, collided.sum()
    np.testing.assert_array_equal(pairs[collided, 1], -100.0)
    # the rest of a colliding segment is its distance costs before the collision (0 when it
    # collides on its first step): a few at most
    assert np.all((pairs[collided, 0] <= 0) & (pairs[collided, 0] > -20)), pairs[collided, 0]
    assert (pairs[collided, 0] < 0).sum() >= 5
    np.testing.assert_allclose(pairs.sum(-1), plain, rtol=1e-6, atol=1e-5)


@pytest.mark.parametrize("sets, message", [
    (["agent.low.terminal_head=true"], "low.terminal_head=True: only the high level"),
    (["agent.high.terminal_head=true", "agent.duration_choice=argmax",
      "agent.high_time_input=true"], "terminal_head=True needs duration_choice='actor'"),
])
def test_terminal_head_where_it_cannot_work_is_refused(sets, message):
    with pytest.raises(ValueError, match=message):
        make_config("hi-ddpg", "ArmObstacle", "quick", sets)

"""The critic's Huber ``δ`` changing during a run (``huber_delta_late`` from
``huber_late_episode`` on): the block takes a per-step ``δ``, and a scheduled run equals a run
trained with the first ``δ`` and continued with the second, bit for bit."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from hiddpg.agents.block import DDPGBlock
from hiddpg.configs import LevelConfig
from hiddpg.presets import make_config
from hiddpg.runs import make_trainer
from hiddpg.train import seed_keys

OBS, ACT, B = 3, 2, 16


def test_the_batch_delta_replaces_the_blocks():
    """Targets 0 but one of 50: the loss is the Huber loss with the batch's δ, not the block's."""
    block = DDPGBlock(obs_dim=OBS, action_dim=ACT, hidden=(8,), actor_lr=1e-3, critic_lr=1e-3,
                      gamma=0.9, tau=0.1, huber_delta=10.0)
    state = block.init(jax.random.PRNGKey(0))
    obs, act = jnp.zeros((B, OBS)), jnp.zeros((B, ACT))
    batch = {"obs": obs, "action": act, "reward": jnp.zeros(B).at[0].set(50.0),
             "next_obs": obs, "terminated": jnp.ones(B, bool)}
    q = float(block.q(state.critic, obs[0], act[0]))
    errors = np.abs(np.asarray(batch["reward"]) - q)

    def huber(d):
        quad = np.minimum(errors, d)
        return float(np.mean(0.5 * quad**2 + d * (errors - quad)))

    for delta in (10.0, 1.0):
        _, m = block.critic_update(state, {**batch, "huber_delta": jnp.float32(delta)})
        np.testing.assert_allclose(float(m["critic_loss"]), huber(delta), rtol=1e-5)
    assert huber(10.0) > 5 * huber(1.0)  # the two δ differ where it is checked


SETS = ["agent.pretrain_episodes=0", "agent.learning_starts=60", "agent.high_learning_starts=4",
        "agent.high.batch_size=4", "agent.low.batch_size=8", "eval_every=3",
        "agent.high.hidden=[16,16]", "agent.low.hidden=[16,16]"]


def _trainer(*sets):
    return make_trainer(make_config("hi-ddpg", "ArmObstacle", "quick", [*SETS, *sets]))


def _leaves(state):
    return [np.asarray(x) for x in jax.tree.leaves(state.agent)]


def test_scheduled_run_equals_one_continued_with_the_late_delta():
    first, late = _trainer("agent.high.huber_delta=10"), _trainer("agent.high.huber_delta=0.01")
    start = first.init_seeds(seed_keys([0, 1]))
    two_phase, _, _ = late.run_chunk_seeds(first.run_chunk_seeds(start, 3)[0], 3)
    sched = _trainer("agent.high.huber_delta=10", "agent.high.huber_delta_late=0.01",
                     "agent.high.huber_late_episode=3")
    s1, _, _ = sched.run_chunk_seeds(sched.init_seeds(seed_keys([0, 1])), 3)
    scheduled, _, _ = sched.run_chunk_seeds(s1, 3)
    assert int(np.asarray(scheduled.agent.high.buffer.size).min()) >= 8  # the high level learned
    for a, b in zip(_leaves(two_phase), _leaves(scheduled), strict=True):
        np.testing.assert_array_equal(a, b)
    # and the switch mattered: δ = 10 throughout ends elsewhere
    start = first.init_seeds(seed_keys([0, 1]))  # (the chunks donate their input state)
    plain, _, _ = first.run_chunk_seeds(first.run_chunk_seeds(start, 3)[0], 3)
    critic = lambda s: jax.tree.leaves(s.agent.high.block.critic)  # noqa: E731
    assert any(not np.array_equal(a, b) for a, b in zip(critic(plain), critic(scheduled),
                                                         strict=True))


@pytest.mark.parametrize("kwargs, message", [
    (dict(huber_delta_late=3.0), "huber_delta_late=3.0 needs huber_delta > 0"),
    (dict(huber_delta=10.0, huber_delta_late=3.0), "huber_late_episode=0 must be an int >= 1"),
    (dict(huber_delta=10.0, huber_delta_late=-1.0), "huber_delta_late=-1.0 must be a finite"),
])
def test_bad_schedules_are_refused(kwargs, message):
    with pytest.raises(ValueError, match=message):
        LevelConfig(**kwargs)

"""The critic's Huber loss (:class:`~hiddpg.configs.HuberLoss`, ``agent.<level>.huber``) and its
``δ`` changing during a run (``late_delta`` from ``late_episode`` on): the block takes the
step's ``δ``, and a scheduled run equals a run trained with the first ``δ`` and continued with
the second, bit for bit."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from hiddpg.agents import huber
from hiddpg.agents.block import DDPGBlock
from hiddpg.agents.transition import Transition
from hiddpg.configs import HuberLoss
from hiddpg.presets import make_config
from hiddpg.runs import make_trainer
from hiddpg.train import seed_keys

OBS, ACT, B = 3, 2, 16


def test_the_critic_loss_is_the_huber_loss_with_the_given_delta():
    """Targets 0 but one of 50: the loss is the Huber loss with the step's δ (a traced value),
    the squared error without one."""
    block = DDPGBlock(obs_dim=OBS, action_dim=ACT, hidden=(8,), actor_lr=1e-3, critic_lr=1e-3,
                      gamma=0.9, tau=0.1)
    state = block.init(jax.random.PRNGKey(0))
    obs, act = jnp.zeros((B, OBS)), jnp.zeros((B, ACT))
    batch = Transition(obs=obs, context=jnp.zeros((B, 0)), action=act,
                       reward=jnp.zeros(B).at[0].set(50.0), next_obs=obs,
                       terminated=jnp.ones(B, bool))
    q = float(block.q(state.critic, obs[0], act[0]))
    errors = np.abs(np.asarray(batch.reward) - q)

    def huber(d):
        quad = np.minimum(errors, d)
        return float(np.mean(0.5 * quad**2 + d * (errors - quad)))

    for delta in (10.0, 1.0):
        _, m = block.critic_update(state, batch, huber_delta=jnp.float32(delta))
        np.testing.assert_allclose(float(m["critic_loss"]), huber(delta), rtol=1e-5)
    assert huber(10.0) > 5 * huber(1.0)  # the two δ differ where it is checked
    _, m = block.critic_update(state, batch)
    np.testing.assert_allclose(float(m["critic_loss"]), np.mean(errors**2), rtol=1e-5)


def test_delta_at_follows_the_schedule():
    sched = HuberLoss(delta=10.0, late_delta=3.0, late_episode=5)
    assert [float(huber.delta_at(sched, e)) for e in (0, 4, 5, 100)] == [10.0, 10.0, 3.0, 3.0]
    np.testing.assert_array_equal(huber.delta_at(sched, jnp.arange(4, 7)), [10.0, 3.0, 3.0])
    assert float(huber.delta_at(HuberLoss(delta=2.0), 10**6)) == 2.0  # no late δ


SETS = ["agent.pretrain_episodes=0", "agent.learning_starts=60", "agent.high_learning_starts=4",
        "agent.high.batch_size=4", "agent.low.batch_size=8", "eval_every=3",
        "agent.high.hidden=[16,16]", "agent.low.hidden=[16,16]"]


def _trainer(*sets):
    return make_trainer(make_config("hi-ddpg", "ArmObstacle", "quick", [*SETS, *sets]))


def _leaves(state):
    return [np.asarray(x) for x in jax.tree.leaves(state.agent)]


@pytest.mark.heavy
def test_scheduled_run_equals_one_continued_with_the_late_delta():
    first, late = _trainer("agent.high.huber.delta=10"), _trainer("agent.high.huber.delta=0.01")
    start = first.init_seeds(seed_keys([0, 1]))
    two_phase, _, _ = late.run_chunk_seeds(first.run_chunk_seeds(start, 3)[0], 3)
    sched = _trainer("agent.high.huber.delta=10", "agent.high.huber.late_delta=0.01",
                     "agent.high.huber.late_episode=3")
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
    (dict(delta=0.0, late_delta=3.0), "HuberLoss.delta=0.0 must be a finite number > 0"),
    (dict(delta=10.0, late_delta=3.0), "HuberLoss.late_episode=0 must be an int >= 1"),
    (dict(delta=10.0, late_delta=-1.0), "HuberLoss.late_delta=-1.0 must be a finite"),
])
def test_bad_schedules_are_refused(kwargs, message):
    with pytest.raises(ValueError, match=message):
        HuberLoss(**kwargs)

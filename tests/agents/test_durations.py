"""HI-DDPG with ``duration_choice="argmax"``: the critic picks the duration, the actor the goal
for it (:mod:`hiddpg.agents.durations`)."""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from hiddpg.agents import durations
from hiddpg.commands.eval import eval_keys
from hiddpg.presets import make_config
from hiddpg.runs import make_trainer
from hiddpg.train import seed_keys

ARGMAX = ["agent.duration_choice=argmax", "agent.hold_choice=false", "agent.hold_explore=0",
          "agent.model_weight=0", "agent.use_model=false"]
BASE = ["agent.learning_starts=0", "agent.pretrain_episodes=0", "agent.high_learning_starts=1",
        "eval_every=1"]


@functools.cache
def _trainer(*sets: str, task: str = "PuckTrajectory2"):
    return make_trainer(make_config("hi-ddpg", task, "quick", [*ARGMAX, *BASE, *sets]))


def _trained(seed: int = 0):
    trainer = _trainer()
    state, _, _ = trainer.run_chunk_seeds(trainer.init_seeds(seed_keys([seed])), 3)
    return trainer, jax.tree.map(lambda x: x[0], state.agent)


def test_the_options_can_be_set_in_any_order_and_clashes_are_named():
    # the constraint holds between fields: set it before or after them
    make_config("hi-ddpg", "PuckTrajectory2", "quick", list(reversed(ARGMAX)))
    with pytest.raises(ValueError, match=r"model_weight=1.0, use_model=True.*needs"):
        make_config("hi-ddpg", "PuckTrajectory2", "quick", ARGMAX[:3])
    with pytest.raises(ValueError, match="high_time_input=False"):
        make_config("hi-ddpg", "PuckObstacle", "quick", ARGMAX)  # no time input there
    with pytest.raises(ValueError, match="two integer durations"):
        make_config("hi-ddpg", "PuckTrajectory2", "quick",
                    [*ARGMAX, "agent.duration_min=15", "agent.duration_max=15.5"])
    with pytest.raises(ValueError, match="'actor' or 'argmax'"):
        make_config("hi-ddpg", "PuckTrajectory2", "quick", ["agent.duration_choice=critic"])
    with pytest.raises(ValueError, match=r"duration_explore=1.5 must be a probability"):
        make_config("hi-ddpg", "PuckTrajectory2", "quick", ["agent.duration_explore=1.5"])


def test_candidate_durations_are_the_integers_clipped_to_the_steps_left():
    agent = _trainer().agent  # T in [1, 30]
    np.testing.assert_array_equal(durations.candidates(agent, jnp.asarray(30)),
                                  np.arange(1, 31))
    np.testing.assert_array_equal(durations.candidates(agent, jnp.asarray(4)),
                                  np.minimum(np.arange(1, 31), 4))
    draws = jax.vmap(lambda k: durations.random_duration(agent, k, jnp.asarray(7)))(
        jax.random.split(jax.random.PRNGKey(0), 2000))
    assert set(np.unique(np.asarray(draws))) == set(range(1, 8))  # every duration that differs


def test_the_policy_takes_the_duration_whose_goal_the_critic_values_most():
    trainer, state = _trained()
    agent, block = trainer.agent, trainer.agent.high.block
    for left in (30, 17, 3):
        obs = jnp.asarray([0.3, -0.2, 0.5, 0.1])
        hobs = agent.high_obs(obs, jnp.asarray(left), 30)
        action = agent.policy_action(state, hobs, jnp.asarray(left))
        values = []
        for t in range(1, 31):  # brute force: the actor's goal for each duration, its value
            tau = agent.duration_unit(jnp.asarray(float(min(t, left))))
            inp = jnp.concatenate([hobs, tau[None]])
            goal = block.mu(state.high.block.actor, inp)
            values.append(float(block.q(state.high.block.critic, inp, goal)))
        best = int(np.argmax(values)) + 1
        _, duration = agent.decode(action)
        assert round(float(duration)) == min(best, left)
        np.testing.assert_allclose(float(agent.high_q(state, hobs, action)), max(values),
                                   rtol=1e-5)


def test_the_high_buffer_holds_the_duration_carried_out_and_the_goal():
    trainer = _trainer()
    state, _, _ = trainer.run_chunk_seeds(trainer.init_seeds(seed_keys([1])), 3)
    buf = state.agent.high.buffer
    n = int(np.asarray(buf.size)[0])
    seg = {k: np.asarray(v)[0, :n] for k, v in buf.data.items()}
    agent = trainer.agent
    assert seg["c"].shape == (n, 1) and seg["a"].shape == (n, agent.goal_dim)
    length = np.round((seg["s"][:, -1] - seg["s2"][:, -1]) * 30)  # steps the segment lasted
    carried = np.asarray(agent.duration_unit(jnp.asarray(length)))
    np.testing.assert_allclose(seg["c"][:, 0], carried, atol=1e-5)
    assert n >= 3 and np.all(length >= 1)


def test_the_target_values_the_next_state_by_the_online_choice_and_the_target_networks():
    trainer, state = _trained(2)
    agent, block = trainer.agent, trainer.agent.high.block
    bs = state.high.block
    # make the target networks differ from the online ones (noise on every weight)
    leaves, tree = jax.tree.flatten(bs.critic)
    keys = jax.random.split(jax.random.PRNGKey(7), len(leaves))
    noisy = [p + 0.3 * jax.random.normal(k, p.shape) for p, k in zip(leaves, keys, strict=True)]
    bs = bs.replace(target_critic=jax.tree.unflatten(tree, noisy))
    s2 = jax.random.uniform(jax.random.PRNGKey(3), (24, 5), minval=-1.0, maxval=1.0)
    s2 = s2.at[:, -1].set(jnp.linspace(0.1, 1.0, 24))  # time left: 3 ... 30 steps
    got = durations.next_value(agent, 30)(block, bs, s2)
    differ = 0
    for i in range(len(s2)):
        left = jnp.maximum(jnp.round(s2[i, -1] * 30), 1.0)
        tau, _, _ = durations.best(agent, bs.actor, bs.critic, s2[i], left)
        own, _, _ = durations.best(agent, bs.target_actor, bs.target_critic, s2[i], left)
        inp = jnp.concatenate([s2[i], tau[None]])
        want = block.q(bs.target_critic, inp, block.mu(bs.target_actor, inp))
        np.testing.assert_allclose(float(got[i]), float(want), rtol=1e-5)
        differ += int(float(own) != float(tau))
    assert differ >= 3  # where the target networks would choose otherwise, the online choice counts
    inputs = jnp.tile(jnp.asarray([[0.1, 0.2, 0.0, 0.0, 0.2, -1.0]]), (500, 1))  # 6 steps left
    redrawn = durations.actor_inputs(agent, 30)(jax.random.PRNGKey(1), inputs)
    _, t = jax.vmap(agent.decode)(jnp.concatenate([jnp.zeros((500, 2)), redrawn[:, -1:]], 1))
    assert set(np.unique(np.round(np.asarray(t)))) == set(range(1, 7))
    np.testing.assert_array_equal(redrawn[:, :-1], inputs[:, :-1])


def test_with_the_reference_low_level_it_learns_the_reference_plan_of_puck_trajectory_2():
    """The high level alone (the puck's LQR controller as the low level): two goals near the
    reference's and one switch, where the actor's duration keeps one goal (docs/results.md)."""
    config = make_config("hi-ddpg", "PuckTrajectory2", "quick", [
        *ARGMAX, "agent.duration_explore=0.5", "agent.high.action_l2=0.1",
        "agent.low_controller=reference", "episodes=3000"])
    trainer = make_trainer(config)
    seeds = [2, 3]
    state, _, _ = trainer.run_chunk_seeds(trainer.init_seeds(seed_keys(seeds)), 3000)
    metrics, traj = trainer.evaluate_seeds(state, eval_keys(0, seeds))
    reference = np.asarray(trainer.env_params.goals)
    for i in range(len(seeds)):
        switch = np.flatnonzero(np.asarray(traj["switch"][i]))
        goals = np.asarray(traj["goal"][i])[switch]
        assert len(switch) == 2 and 13 <= switch[1] <= 17, switch
        np.testing.assert_array_less(np.linalg.norm(goals - reference, axis=1), 0.3)
        assert float(metrics["return"][i]) > -14  # the reference plan: -10

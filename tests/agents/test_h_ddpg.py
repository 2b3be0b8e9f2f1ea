"""h-DDPG (spec §4): ε-greedy meta-critic, movement patterns, switch count, DQN update, replay
routing, learning on PuckTrajectory1, determinism and vmap over seeds.

One training run (quick preset, 60 episodes, seeds 0 and 1, vmapped, in chunks of 15 episodes)
is shared by the learning, schedule and contract tests; one single-seed chunk is compiled for
the determinism and vmap comparisons.
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np
import probes
import pytest

from hiddpg.agents import make_agent
from hiddpg.agents.base import EPISODE_KEYS
from hiddpg.agents.h_ddpg import (
    count_switches,
    epsilon_greedy,
    epsilon_schedule,
    make_hddpg,
)
from hiddpg.agents.skills import ArmSkills, PuckSkills, skill_patterns
from hiddpg.agents.transition import Transition
from hiddpg.configs import HDDPGConfig, from_dict, to_dict
from hiddpg.envs import make as make_env
from hiddpg.presets import make_config

EPISODES, CHUNK = 60, 15
SEEDS = (0, 1)


# -- ε-greedy and its schedule ------------------------------------------------------------------
def test_epsilon_zero_is_the_argmax_and_one_is_uniform():
    keys = jax.random.split(jax.random.PRNGKey(0), 4000)
    qs = jax.random.normal(jax.random.PRNGKey(1), (4000, 4))
    greedy = jax.vmap(epsilon_greedy, in_axes=(0, 0, None))(keys, qs, 0.0)
    np.testing.assert_array_equal(greedy, np.argmax(np.asarray(qs), axis=-1))
    q = jnp.array([0.0, 5.0, -1.0, 2.0])  # argmax 1
    uniform = jax.vmap(epsilon_greedy, in_axes=(0, None, None))(keys, q, 1.0)
    freq = np.bincount(np.asarray(uniform), minlength=4) / 4000
    np.testing.assert_allclose(freq, 0.25, atol=0.03)  # 4.4 standard errors
    half = jax.vmap(epsilon_greedy, in_axes=(0, None, None))(keys, q, 0.5)
    assert np.mean(np.asarray(half) == 1) == pytest.approx(0.5 + 0.5 / 4, abs=0.03)


def test_epsilon_schedule_is_linear_and_ends_at_the_decay_episode():
    eps = [float(epsilon_schedule(e, 1.0, 0.1, 20)) for e in (0, 5, 10, 20, 21, 1000)]
    np.testing.assert_allclose(eps, [1.0, 0.775, 0.55, 0.1, 0.1, 0.1], rtol=1e-6)


def test_presets_derive_the_decay_from_the_budget():
    assert make_config("h-ddpg", "PuckTrajectory1", "quick",
                       ["episodes=50"]).agent.epsilon_decay_episodes == 10
    assert make_config("h-ddpg", "ArmObstacle", "paper").agent.epsilon_decay_episodes == 600
    cfg = make_config("h-ddpg", "PuckObstacle", "quick",
                      ["episodes=50", "agent.epsilon_decay_episodes=7"])
    assert cfg.agent.epsilon_decay_episodes == 7
    assert from_dict(to_dict(cfg)) == cfg
    with pytest.raises(ValueError, match="epsilon_end=0.5 .*epsilon_start=0.2"):
        HDDPGConfig(epsilon_start=0.2, epsilon_end=0.5)


# -- movement patterns --------------------------------------------------------------------------
def test_puck_skills_reach_the_requested_velocity_along_their_direction():
    env, params = make_env("PuckObstacle")
    skills = PuckSkills(max_speed=3.0)
    directions = np.array([[1, 0], [-1, 0], [0, 1], [0, -1]], np.float32)
    k1, k2, k3 = jax.random.split(jax.random.PRNGKey(0), 3)
    n = 400
    skill = jax.random.randint(k1, (n,), 0, 4)
    unit = jax.random.uniform(k2, (n, 1), minval=-1.0, maxval=1.0)
    velocity = jax.random.uniform(k3, (n, 2), minval=-1.5, maxval=1.5)
    x = jnp.concatenate([jnp.tile(jnp.array([0.5, -1.0]), (n, 1)), velocity], axis=1)

    @jax.jit
    @jax.vmap
    def one_step(skill, unit, x):
        _, state = env.reset(k1, params, {"init_state": x})
        action = skills.env_action(skill, unit, x, params)
        return action, env.step(k1, state, action, params).obs[2:]

    action, v_next = (np.asarray(a) for a in one_step(skill, unit, x))
    wanted = 3.0 * (np.asarray(unit) + 1) / 2 * directions[np.asarray(skill)]
    free = np.all(np.abs(action) < 1.0, axis=1)
    assert free.sum() > 80 and (~free).sum() > 80
    # within the force bound the velocity after one step is exactly m d_k
    np.testing.assert_allclose(v_next[free], wanted[free], atol=1e-5)
    # at the bound an entry saturates and the velocity moves towards m d_k
    np.testing.assert_allclose(np.abs(action[~free]).max(axis=1), 1.0)
    v = np.asarray(velocity)
    closer = (np.linalg.norm(v_next - wanted, axis=1) < np.linalg.norm(v - wanted, axis=1))
    assert np.all(closer[~free])
    # from rest the +x skill at full speed needs 30 > force_max = 10: the force is clipped
    rest = jnp.zeros(4)
    np.testing.assert_allclose(skills.env_action(0, jnp.ones(1), rest, params), [1.0, 0.0])
    np.testing.assert_allclose(skills.env_action(3, jnp.ones(1), rest, params), [0.0, -1.0])
    np.testing.assert_allclose(skills.env_action(2, -jnp.ones(1), rest, params), [0.0, 0.0])


def test_arm_skills_activate_only_their_agonists():
    names = ("shoulder flexor", "shoulder extensor", "elbow flexor", "elbow extensor",
             "biarticular flexor", "biarticular extensor")  # envs/muscles.py order
    agonists = {"S-F/Eb-F": ("shoulder flexor", "elbow flexor", "biarticular flexor"),
                "S-F/Eb-Ex": ("shoulder flexor", "elbow extensor"),
                "S-Ex/Eb-F": ("shoulder extensor", "elbow flexor"),
                "S-Ex/Eb-Ex": ("shoulder extensor", "elbow extensor", "biarticular extensor")}
    env, params = make_env("ArmObstacle")
    skills = skill_patterns(env)
    assert isinstance(skills, ArmSkills) and skills.actor_dims == (3, 2, 2, 3)
    units = jax.random.uniform(jax.random.PRNGKey(0), (4, 3), minval=-1.0, maxval=1.0)
    for k, name in enumerate(skills.names):
        action = np.asarray(skills.env_action(k, units[k], jnp.zeros(4), params))
        expected = np.zeros(6)
        for j, muscle in enumerate(agonists[name]):
            expected[names.index(muscle)] = (float(units[k, j]) + 1) / 2
        np.testing.assert_allclose(action, expected, rtol=1e-6, err_msg=name)


def test_an_env_without_patterns_is_an_error_naming_it():
    with pytest.raises(ValueError, match="ConstantReward.*PuckTrajectory1-3.*ArmObstacle"):
        make_hddpg(HDDPGConfig(), probes.ConstantReward())
    with pytest.raises(TypeError, match="HDDPGConfig"):
        make_agent("h-ddpg", make_config("ddpg", "PuckObstacle", "quick").agent,
                   make_env("PuckObstacle")[0])


# -- switches, the DQN update, replay routing ---------------------------------------------------
def test_switches_count_skill_changes_while_alive():
    skill = jnp.array([0, 0, 1, 1, 2, 0, 0, 3, 1])
    alive = jnp.array([1, 1, 1, 1, 1, 1, 1, 0, 0], bool)
    assert int(count_switches(skill, alive)) == 3  # 0→1, 1→2, 2→0; 0→3→1 after the end
    assert int(count_switches(skill, jnp.ones(9, bool))) == 5
    assert int(count_switches(jnp.zeros(9, jnp.int32), jnp.ones(9, bool))) == 0


def test_meta_update_fits_the_dqn_target():
    _, agent, _, init, _, _ = setup()
    state = init(jax.random.PRNGKey(0))
    k = jax.random.split(jax.random.PRNGKey(1), 3)
    batch = Transition(obs=jax.random.normal(k[0], (8, 4)), context=jnp.zeros((8, 0)),
                       action=jnp.arange(8) % 4, reward=jax.random.normal(k[2], (8,)),
                       next_obs=jax.random.normal(k[1], (8, 4)),
                       terminated=jnp.arange(8) % 3 == 0)
    meta = state.meta.replace(target=jax.tree_util.tree_map(lambda x: 2 * x, state.meta.params))
    new, loss = jax.jit(agent.meta_update)(meta, batch)
    q = np.asarray(agent.meta_q(meta.params, batch.obs))[np.arange(8), batch.action]
    next_q = np.asarray(agent.meta_q(meta.target, batch.next_obs)).max(-1)
    y = np.asarray(batch.reward) + 0.99 * (1 - np.asarray(batch.terminated)) * next_q
    assert float(loss) == pytest.approx(np.mean((y - q) ** 2), rel=1e-5)
    tau = agent.config.meta.tau
    jax.tree_util.tree_map(lambda t, p, o: np.testing.assert_allclose(
        t, tau * p + (1 - tau) * o, rtol=1e-5, atol=1e-7), new.target, new.params, meta.target)


def test_each_transition_goes_to_the_meta_replay_and_the_chosen_skills():
    _, agent, _, init, _, _ = setup()
    state = init(jax.random.PRNGKey(0))
    obs, unit = jnp.ones(4), jnp.full((1,), 0.5)
    store = jax.jit(agent._store)
    state = store(state, obs, jnp.int32(2), unit, jnp.float32(-1.0), obs, False, True)
    state = store(state, obs, jnp.int32(0), unit, jnp.float32(-1.0), obs, False, False)
    np.testing.assert_array_equal(state.skill_buffers.size, [0, 0, 1, 0])
    assert int(state.meta_buffer.size) == 1 and int(state.meta_buffer.data.action[0]) == 2
    np.testing.assert_array_equal(state.skill_buffers.data.action[2, 0], [0.5])


@functools.cache
def setup():
    """The quick preset's agent on PuckTrajectory1 with jitted ``init`` and a training chunk."""
    cfg = make_config("h-ddpg", "PuckTrajectory1", "quick", [f"episodes={EPISODES}"])
    env, params = make_env(cfg.task)
    agent = make_agent(cfg.algo, cfg.agent, env)

    def chunk(state, key):
        step = lambda s, k: agent.train_episode(k, s, params)
        return jax.lax.scan(step, state, jax.random.split(key, CHUNK))

    init = jax.jit(lambda k: agent.init(k, params))
    evaluate = jax.jit(jax.vmap(lambda s, k: agent.evaluate(k, s, params)))
    return cfg, agent, params, init, chunk, evaluate


# -- one training run shared by the rest ---------------------------------------------------------
@functools.cache
def trained():
    cfg, agent, params, init, chunk, evaluate = setup()
    keys = jnp.stack([jax.random.PRNGKey(s) for s in SEEDS])
    state = jax.tree_util.tree_map(lambda *xs: jnp.stack(xs), *[init(k) for k in keys])
    state0, run, chunks = state, jax.jit(jax.vmap(chunk)), []
    for i in range(EPISODES // CHUNK):
        state, m = run(state, jax.vmap(lambda k, i=i: jax.random.fold_in(k, i))(keys))
        chunks.append(m)
    metrics = jax.tree_util.tree_map(lambda *xs: np.concatenate(xs, axis=1), *chunks)
    eval_m, traj = evaluate(state, keys)
    return state0, state, metrics, chunks[0], jax.device_get((eval_m, traj))


@pytest.mark.slow
def test_learned_policy_beats_a_uniformly_random_skill_policy():
    cfg, *_ = setup()
    _, state, metrics, _, (eval_m, traj) = trained()
    # the first learning_starts = 300 steps (10 episodes) choose skills and speeds uniformly
    n_random = cfg.agent.skill.learning_starts // 30
    random_returns = np.asarray(metrics["return"][:, :n_random])
    final = np.asarray(eval_m["return"])
    print(f"random-skill returns: mean {random_returns.mean():.1f}, best "
          f"{random_returns.max():.1f}; final greedy returns {final}")
    assert random_returns.mean() < -30.0
    assert np.all(final > random_returns.mean() + 15.0)
    # trajectory contract for hiddpg eval / render
    assert set(EPISODE_KEYS) <= set(eval_m)
    assert traj["skill"].shape == (2, 30) and traj["skill"].dtype == np.int32
    assert traj["obs"].shape == (2, 30, 4) and traj["action"].shape == (2, 30, 2)
    switches = [count_switches(s, a) for s, a in zip(traj["skill"], traj["alive"], strict=True)]
    np.testing.assert_array_equal(eval_m["switches"], switches)


@pytest.mark.slow
def test_schedule_counters_and_replays_of_the_run():
    cfg, *_ = setup()
    _, state, m, _, _ = trained()
    episodes = np.arange(EPISODES)
    expected_eps = np.maximum(1.0 - 0.9 * episodes / 12, 0.1)  # 20 % of 60 episodes
    np.testing.assert_allclose(m["epsilon"][0], expected_eps, rtol=1e-6)
    np.testing.assert_array_equal(m["env_steps"][0], 30 * (episodes + 1))
    np.testing.assert_array_equal(m["length"], 30)
    np.testing.assert_array_equal(m["return"], m["env_return"])
    # every step is in the meta replay and in exactly one skill's replay
    np.testing.assert_array_equal(state.meta_buffer.size, 30 * EPISODES)
    np.testing.assert_array_equal(state.skill_buffers.size.sum(axis=1), 30 * EPISODES)
    assert np.all(np.asarray(state.skill_buffers.size) > 0)
    n_random = cfg.agent.skill.learning_starts // 30
    np.testing.assert_array_equal(m["meta_loss"][:, :n_random], 0.0)
    assert np.all(np.asarray(m["meta_loss"][:, n_random:]) > 0)
    assert np.all(np.asarray(m["switches"][:, :n_random]) > 10)  # uniformly random skills
    np.testing.assert_array_equal(state.meta.opt[0].count, 30 * (EPISODES - n_random))




@pytest.mark.slow
def test_same_key_same_run_and_vmap_equals_single_seeds():
    state0, _, _, first, _ = trained()
    run = jax.jit(setup()[4])
    for i, seed in enumerate(SEEDS):
        key = jax.random.fold_in(jax.random.PRNGKey(seed), 0)
        s = jax.tree_util.tree_map(lambda x, i=i: x[i], state0)
        _, m = run(s, key)
        _, again = run(s, key)
        for k in m:
            np.testing.assert_array_equal(m[k], again[k])
            np.testing.assert_allclose(first[k][i], m[k], rtol=1e-5, atol=1e-5, err_msg=k)

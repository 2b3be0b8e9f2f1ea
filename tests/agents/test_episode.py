"""The episode harness (:mod:`hiddpg.agents.episode`): the environment is stepped with the
agent's ``"env"`` stream, the steps after the episode's end are masked, the sums and the
trajectory cover the horizon, learning rates decay in training only, the random phase follows
the agent's environment-step count."""

from __future__ import annotations

import dataclasses
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from hiddpg.agents.episode import EpisodeMetrics, decay_factor, run_episode
from hiddpg.envs.base import Environment, StepResult

HORIZON, END = 6, 3  # the episode terminates after its 3rd step


@struct.dataclass
class _State:
    x: jax.Array
    t: jax.Array


@struct.dataclass
class _Params:
    max_steps: int = struct.field(pytree_node=False, default=HORIZON)


class Counter(Environment):
    """x grows by the action each step; the reward is x; it terminates after END steps."""

    name, obs_dim, state_dim, action_dim, dt = "Counter", 1, 1, 1, 1.0

    def default_params(self, **overrides):
        return _Params(**overrides)

    def dynamics(self, x, action, params):
        return x + action

    def reset(self, key, params, options=None):
        return jnp.zeros(1), _State(jnp.zeros(1), jnp.zeros((), jnp.int32))

    def step(self, key, state, action, params):
        x, t = state.x + action, state.t + 1
        noise = jax.random.uniform(key)  # the env's key shows in the info
        return StepResult(obs=x, state=_State(x, t), reward=x[0], terminated=t >= END,
                          truncated=t >= params.max_steps, info={"noise": noise})


@struct.dataclass
class _Learner:
    env_steps: jax.Array
    episodes: jax.Array
    lr: jax.Array


@dataclasses.dataclass(frozen=True)
class Toy:
    """Acts 1.0 (0.5 in the random phase), counts what the harness shows it."""

    env: Environment
    learning_starts: int = 4

    def step_keys(self, key, train):
        env, own = jax.random.split(key)
        return {"env": env, "own": own}

    def decay(self, state):
        return state.replace(lr=0.1 * decay_factor(0.5, 1, state.episodes))

    def begin(self, state, obs, horizon, train):
        return jnp.zeros(()), {"ret": jnp.zeros(()), "steps": jnp.zeros((), jnp.int32)}

    def act(self, state, inner, obs, alive, keys, random_phase, env_params, horizon, train):
        action = jnp.where(random_phase, 0.5, 1.0)[None]
        return inner + 1, action, (random_phase, keys["env"])

    def observe(self, state, inner, obs, info, res, alive, keys, random_phase, horizon, train):
        reward = jnp.where(alive, res.reward, 0.0)
        state = state.replace(env_steps=state.env_steps + alive.astype(jnp.int32))
        out = {"obs": obs, "alive": alive, "random": info[0], "noise": res.info["noise"],
               "env_key": info[1]}
        return state, inner, {"ret": reward, "steps": alive.astype(jnp.int32)}, out

    def finish(self, state, inner, sums, traj, train):
        state = state.replace(episodes=state.episodes + int(train))
        return state, EpisodeMetrics(sums["ret"], sums["ret"], sums["steps"], inner,
                                     {"lr": state.lr})


def _run(state: Any, train: bool, key: int = 0):
    agent = Toy(Counter())
    return run_episode(agent, jax.random.PRNGKey(key), state, Counter().default_params(), train)


def _learner(env_steps=0, episodes=0):
    return _Learner(jnp.asarray(env_steps, jnp.int32), jnp.asarray(episodes, jnp.int32),
                    jnp.asarray(1.0))


def test_the_steps_after_the_end_are_masked():
    state, metrics, traj = _run(_learner(env_steps=100), train=False)
    np.testing.assert_array_equal(np.asarray(traj["alive"]), [1, 1, 1, 0, 0, 0])
    # obs before each action: 0, 1, 2, then frozen at the last one after the end (3)
    np.testing.assert_array_equal(np.asarray(traj["obs"])[:, 0], [0, 1, 2, 3, 3, 3])
    assert float(metrics.ret) == 1 + 2 + 3 and int(metrics.length) == END
    assert int(metrics.switches) == HORIZON  # the agent acted on every step of the scan
    assert int(state.env_steps) == 100 + END


def test_the_environment_steps_with_the_agents_env_stream():
    _, _, traj = _run(_learner(), train=False, key=7)
    k_reset, k_steps = jax.random.split(jax.random.PRNGKey(7))
    expected = [jax.random.split(k, 2)[0] for k in jax.random.split(k_steps, HORIZON)]
    np.testing.assert_array_equal(np.asarray(traj["env_key"]), np.stack(expected))
    noise = [float(jax.random.uniform(k)) for k in expected]
    np.testing.assert_allclose(np.asarray(traj["noise"]), noise)


def test_the_random_phase_follows_the_agents_step_count():
    _, _, traj = _run(_learner(env_steps=2), train=True)  # learning_starts = 4
    np.testing.assert_array_equal(np.asarray(traj["random"]), [1, 1, 0, 0, 0, 0])


def test_learning_rates_decay_in_training_only():
    state, metrics, _ = _run(_learner(episodes=3), train=True)
    assert float(metrics.extra["lr"]) == np.float32(0.1 * 0.5**3)
    assert int(state.episodes) == 4
    state, metrics, _ = _run(_learner(episodes=3), train=False)
    assert float(metrics.extra["lr"]) == 1.0 and int(state.episodes) == 3


def test_metrics_flatten_to_the_engines_names():
    _, metrics, _ = _run(_learner(), train=True)
    flat = metrics.as_dict()
    assert set(flat) == {"return", "env_return", "length", "switches", "lr"}
    assert float(flat["return"]) == float(metrics.ret)

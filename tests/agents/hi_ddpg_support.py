"""Shared pieces of the HI-DDPG tests: a small reaching task, the configs, compiled runs whose
states after each episode are kept (the checks that rebuild an episode are in
``hi_ddpg_checks``).

Compiling one HI-DDPG training episode takes seconds on CPU, so each agent is compiled once —
a ``lax.scan`` over a few episodes returning the state after each — and the tests share the
runs (``functools.cache``). The initial weights are drawn by numpy into the pytree that
``agent.init`` builds (checked against ``jax.eval_shape(agent.init)``): compiling ``agent.init``
(one ``jax.random`` call per layer) costs as much as compiling an episode.
"""

from __future__ import annotations

import dataclasses
import functools
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from hiddpg.agents import buffer, make_agent
from hiddpg.agents.block import BlockState
from hiddpg.agents.hi_ddpg import HIDDPG, HIDDPGState, make_hiddpg
from hiddpg.agents.level import LevelState
from hiddpg.agents.model_grad import ModelState
from hiddpg.agents.transition import example
from hiddpg.configs import HIDDPGConfig, LevelConfig, NoiseConfig
from hiddpg.envs.base import Environment, GoalSpace, StepResult, replace_params
from hiddpg.envs.puckworld import PuckTrajectory1

TARGET = (1.0, 0.5)


# -- a small probe environment with a goal space ------------------------------------------------
@struct.dataclass
class ReachParams:
    max_steps: int = struct.field(pytree_node=False, default=12)
    terminate_at: Any = 0  # traced (int32): one compiled agent serves both; 0 = never


@struct.dataclass
class ReachState:
    x: jax.Array
    t: jax.Array


class Reach(Environment):
    """``x' = x + dt (a0, a1, a0 - a1)``, reward ``-|x[:2] - TARGET|``; random start in
    ``[-1, 1]^3``; terminates after ``terminate_at`` actions (if > 0), else truncated at
    ``max_steps``. The goal fixes entries 0 and 2 (entry 1 of a goal is 0)."""

    name = "Reach"
    obs_dim = state_dim = 3
    action_dim = 2
    dt = 0.25
    goal_space = GoalSpace((0, 2), (-1.5, -0.5), (2.0, 1.0))

    def default_params(self, **overrides: Any) -> ReachParams:
        p = replace_params(ReachParams(), overrides)
        return p.replace(terminate_at=jnp.asarray(p.terminate_at, jnp.int32))

    def dynamics(self, x, action, params):
        a = self.clip_action(action)
        return x + self.dt * jnp.stack([a[0], a[1], a[0] - a[1]])

    def reset(self, key, params, options=None):
        x = jax.random.uniform(key, (3,), minval=-1.0, maxval=1.0)
        return x, ReachState(x=x, t=jnp.zeros((), jnp.int32))

    def step(self, key, state, action, params) -> StepResult:
        x, t = self.dynamics(state.x, action, params), state.t + 1
        reward = -jnp.linalg.norm(x[:2] - jnp.asarray(TARGET))
        terminated = (params.terminate_at > 0) & (t >= params.terminate_at)
        truncated = (t >= params.max_steps) & ~terminated
        return StepResult(x, ReachState(x=x, t=t), reward, terminated, truncated, {})


def _level(gamma: float, sigma: float = 0.2, buffer_size: int = 128) -> LevelConfig:
    return LevelConfig(hidden=(8, 8), lr=1e-3, gamma=gamma, tau=0.05, batch_size=4,
                       buffer_size=buffer_size, noise=NoiseConfig(sigma=sigma))


HORIZON, EPISODES, STARTS, COST = 12, 6, 30, 3.5
BASE = HIDDPGConfig(high=_level(0.99), low=_level(0.95), duration_min=1.0, duration_max=8.0,
                    switch_cost=COST, learning_starts=STARTS, high_learning_starts=1)
#: on PuckTrajectory1: HI-DDPG-wo-model, low-level pre-training for 2 episodes, a noise-free
#: high level (whose fresh actor gives T = 5), the paper's switch cost
PUCK_EPISODES, PUCK_STARTS = 4, 6
PUCK = dataclasses.replace(BASE, high=_level(0.99, sigma=0.0), duration_max=9.0,
                           switch_cost=10.0, pretrain_episodes=2, learning_starts=PUCK_STARTS)


# -- running and reading agents ---------------------------------------------------------------
class Run(NamedTuple):
    agent: HIDDPG
    env: Environment
    params: Any
    init: Any  # the state before the first episode
    states: Any  # the state after each episode (leading episode axis)
    metrics: dict  # per episode
    final: Any  # the state after the last episode

    def state(self, e: int) -> Any:
        """The state after episode ``e`` (1-based; 0 = the initial state)."""
        if e == 0:
            return self.init
        return jax.tree_util.tree_map(lambda x: x[e - 1], self.states)


def _draw(shapes, rng: np.random.Generator, final_scale: float | None):
    """Parameters as the networks module initialises them (hidden layers ``U(±1/sqrt(fan_in))``,
    biases 0, output layer ``U(±final_scale)`` for actor and critic), drawn by numpy."""

    def draw(path, sd):
        names = [getattr(p, "key", None) for p in path]
        if "out" in names and final_scale is not None:
            return jnp.asarray(rng.uniform(-final_scale, final_scale, sd.shape), sd.dtype)
        if names[-1] == "bias":
            return jnp.zeros(sd.shape, sd.dtype)
        bound = 1.0 / np.sqrt(sd.shape[0])
        return jnp.asarray(rng.uniform(-bound, bound, sd.shape), sd.dtype)

    return jax.tree_util.tree_map_with_path(draw, shapes)


def _level_state(level, shapes, rng) -> LevelState:
    block, model = level.block, level.model
    actor, critic = _draw(shapes.block.actor, rng, 3e-3), _draw(shapes.block.critic, rng, 3e-3)
    block_state = block.set_learning_rates(
        BlockState(actor, critic, actor, critic, block.actor_tx.init(actor),
                   block.critic_tx.init(critic)), block.actor_lr, block.critic_lr)
    params = _draw(shapes.model.params, rng, None)
    model_state = model.set_learning_rate(ModelState(params, model.optimizer.init(params)),
                                          model.lr)
    return LevelState(block_state, model_state,
                      buffer.init(example(level.state_dim, level.action_dim, level.context_dim),
                                  level.config.buffer_size))


@functools.cache
def _initial_state(agent: HIDDPG, params: Any, seed: int) -> HIDDPGState:
    """What ``agent.init`` builds, with numpy drawing the initial weights: compiling
    ``agent.init`` (flax init, one ``jax.random`` call per layer) costs as much as compiling a
    whole training episode, twice that under ``vmap``. ``params`` is a hashable key."""
    rng = np.random.default_rng(seed)
    shapes = jax.eval_shape(agent.init, jax.random.PRNGKey(0), params.value)
    zero = jnp.zeros((), jnp.int32)
    state = HIDDPGState(_level_state(agent.high, shapes.high, rng),
                        _level_state(agent.low, shapes.low, rng), zero, zero)
    got = jax.tree_util.tree_map(lambda x: (x.shape, x.dtype), state)
    want = jax.tree_util.tree_map(lambda x: (x.shape, x.dtype), shapes)
    assert got == want, "the same pytree as agent.init"
    return state


class _Key:
    """Wraps unhashable env params for ``functools.cache`` (identity)."""

    def __init__(self, value: Any):
        self.value = value


def _run_fn(agent: HIDDPG, episodes: int):
    def run(state, key, params):
        def body(s, k):
            s, m = agent.train_episode(k, s, params)
            return s, (s, m)

        return jax.lax.scan(body, state, jax.random.split(key, episodes))[1]

    return run


@functools.cache
def _compiled(agent: HIDDPG, episodes: int, batched: bool = False):
    run = _run_fn(agent, episodes)
    return jax.jit(jax.vmap(run, in_axes=(0, 0, None)) if batched else run)


@functools.cache
def _params_key(env: Environment, **env_kw) -> _Key:
    return _Key(env.default_params(**env_kw))


@functools.cache
def _run(agent: HIDDPG, env: Environment, episodes: int, seed: int = 0, **env_kw) -> Run:
    params = _params_key(env, **env_kw)
    init = _initial_state(agent, params, seed)
    states, metrics = jax.device_get(
        _compiled(agent, episodes)(init, jax.random.PRNGKey(seed), params.value))
    final = jax.tree_util.tree_map(lambda x: x[-1], states)
    return Run(agent, env, params.value, jax.device_get(init), states, metrics, final)


def base_run(**env_kw) -> Run:
    return _run(make_hiddpg(BASE, Reach()), Reach(), EPISODES, **env_kw)


def puck_agent() -> HIDDPG:
    return make_agent("hi-ddpg-wo-model", PUCK, PuckTrajectory1())


def puck_run(seed: int = 0) -> Run:
    return _run(puck_agent(), PuckTrajectory1(), PUCK_EPISODES, seed)


def _equal(a, b) -> bool:
    """Bitwise equality of two pytrees."""
    same = jax.tree_util.tree_map(lambda x, y: np.array_equal(np.asarray(x), np.asarray(y)), a, b)
    return jax.tree_util.tree_all(same)


def _params(level_state) -> dict:
    """Everything a level learns: networks, targets, model, optimiser states (not the buffer)."""
    return {"block": level_state.block, "model": level_state.model}


def _count(level_state) -> int:
    """The number of updates a level made (its actor's Adam step count)."""
    return int(level_state.block.actor_opt.count)


def _random_high_actor(state, seed: int):
    """The high actor with random weights ``N(0, 4/fan_in)`` and biases ``N(0, 1)``: its
    (g, T) then vary with the state (a fresh DDPG actor outputs ~0, i.e. the same goal and
    duration at every switch)."""
    rng = np.random.default_rng(seed)

    def draw(x):
        std = 2.0 / np.sqrt(x.shape[0]) if x.ndim == 2 else 1.0
        return jnp.asarray(rng.normal(0.0, std, x.shape), x.dtype)

    actor = jax.tree_util.tree_map(draw, state.high.block.actor)
    return state.replace(high=state.high.replace(block=state.high.block.replace(actor=actor)))

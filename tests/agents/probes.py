"""Probe environments for value-based agents (after Andy Jones' "debugging RL" probes / rejax).

Each probe isolates one thing an actor–critic must get right and has a known answer:

* :class:`ConstantReward` — constant obs, reward 1, one step: ``Q = 1`` (critic fits a constant).
* :class:`ObsReward` — obs ±1 at random, reward = obs, one step: ``Q(s) = s`` (uses the obs).
* :class:`ActionReward` — constant obs, reward ``-(a - target)²``, one step: ``μ = target``,
  ``Q(s, μ(s)) = 0`` (actor follows ``dQ/da``). :class:`ActionReward01` uses the ``[0, 1]`` box.
* :class:`TwoStep` — obs 0 then 1, rewards 0 then 1, terminates after 2 steps: ``Q(s0) = γ``,
  ``Q(s1) = 1`` (discounting, termination). ``max_steps > 2`` leaves steps after the end.
* :class:`TruncatedReward` — constant obs, reward 1, never terminates, truncated after
  ``max_steps``: ``Q = 1 / (1 − γ)`` (bootstrap through truncation).
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
from flax import struct

from hiddpg.envs.base import Environment, GoalSpace, StepResult, replace_params


@struct.dataclass
class ProbeParams:
    max_steps: int = struct.field(pytree_node=False, default=1)
    target: float = 0.5


@struct.dataclass
class ProbeState:
    x: jax.Array
    t: jax.Array


class _Probe(Environment):
    obs_dim = 1
    state_dim = 1
    action_dim = 1
    dt = 1.0
    goal_space = GoalSpace((0,), (-1.0,), (1.0,))
    default_max_steps = 1

    def default_params(self, **overrides: Any) -> ProbeParams:
        return replace_params(ProbeParams(max_steps=self.default_max_steps), overrides)

    def dynamics(self, x: jax.Array, action: jax.Array, params: Any) -> jax.Array:
        return x

    def reset(self, key: jax.Array, params: Any, options: Any = None):
        x = self._initial(key)
        return x, ProbeState(x=x, t=jnp.zeros((), jnp.int32))

    def _initial(self, key: jax.Array) -> jax.Array:
        return jnp.zeros((1,), jnp.float32)

    def _reward(self, state: ProbeState, action: jax.Array, params: Any) -> jax.Array:
        raise NotImplementedError

    def _terminated(self, t: jax.Array) -> jax.Array:
        return t >= 1

    def _next_x(self, state: ProbeState) -> jax.Array:
        return state.x

    def step(self, key, state, action, params) -> StepResult:
        action = self.clip_action(action)
        reward = self._reward(state, action, params)
        t = state.t + 1
        new = ProbeState(x=self._next_x(state), t=t)
        terminated = self._terminated(t)
        truncated = (t >= params.max_steps) & ~terminated
        return StepResult(new.x, new, jnp.asarray(reward, jnp.float32), terminated, truncated, {})


class ConstantReward(_Probe):
    name = "ConstantReward"

    def _reward(self, state, action, params):
        return jnp.ones(())


class ObsReward(_Probe):
    name = "ObsReward"

    def _initial(self, key):
        return jnp.where(jax.random.bernoulli(key), 1.0, -1.0).reshape(1).astype(jnp.float32)

    def _reward(self, state, action, params):
        return state.x[0]


class ActionReward(_Probe):
    name = "ActionReward"

    def _reward(self, state, action, params):
        return -((action[0] - params.target) ** 2)


class ActionReward01(ActionReward):
    """``ActionReward`` on the muscle-style box ``[0, 1]``."""

    name = "ActionReward01"
    action_low = 0.0
    action_high = 1.0


class TwoStep(_Probe):
    name = "TwoStep"
    default_max_steps = 2

    def _reward(self, state, action, params):
        return (state.t == 1).astype(jnp.float32)

    def _terminated(self, t):
        return t >= 2

    def _next_x(self, state):
        return jnp.ones((1,), jnp.float32)


class TruncatedReward(_Probe):
    name = "TruncatedReward"

    def _reward(self, state, action, params):
        return jnp.ones(())

    def _terminated(self, t):
        return jnp.zeros((), bool)


def make_train(agent: Any, params: Any, episodes: int):
    """A jitted ``train(key) -> (state, metrics)``: init, then ``episodes`` training episodes in
    one ``lax.scan`` (the way the engine runs an agent); metrics have a leading episode axis."""

    def train(key: jax.Array):
        k_init, k_run = jax.random.split(key)
        state = agent.init(k_init, params)
        step = lambda s, k: agent.train_episode(k, s, params)
        return jax.lax.scan(step, state, jax.random.split(k_run, episodes))

    return jax.jit(train)


def q_value(agent: Any, state: Any, obs: float, action: float | None = None) -> float:
    """A DDPG agent's ``Q(obs, action)`` on a 1-D probe; ``action=None`` means ``μ(obs)``."""
    block = agent.block
    o = jnp.full((1, 1), obs, jnp.float32)
    a = block.act(state.block, o) if action is None else jnp.full((1, 1), action, jnp.float32)
    return float(block.q(state.block.critic, o, a)[0])


def policy(agent: Any, state: Any, obs: float) -> float:
    """A DDPG agent's unit action ``μ(obs)`` on a 1-D probe."""
    return float(agent.block.act(state.block, jnp.full((1,), obs, jnp.float32))[0])

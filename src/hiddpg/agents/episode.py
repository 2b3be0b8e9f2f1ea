"""One episode of any agent: a ``lax.scan`` over the task's horizon, shared by DDPG, h-DDPG and
HI-DDPG (Alg. 1 lines 3-6 for HI-DDPG; the same loop for the flat agents).

The harness owns what every agent does alike: the environment's reset and step, the learning
rates' decay at the episode's start, the random phase (the first ``learning_starts``
environment steps of a run), the mask after the episode's end (the environment state and the
observation frozen, nothing stored, learned or counted), the per-step sums and the trajectory.
An agent (:class:`EpisodeAgent`) supplies what differs: its per-episode state, how it acts,
and what it makes of a step — its rewards and, in training, storing and learning.
"""

from __future__ import annotations

from typing import Any, Protocol

import jax
import jax.numpy as jnp
from flax import struct

from hiddpg.envs.base import Environment


@struct.dataclass
class EpisodeMetrics:
    """What one episode reports (every agent; ``extra`` holds the agent's own, e.g. losses).

    Attributes:
        ret: the return the agent maximises (HI-DDPG: the high level's, switch costs included).
        env_return: the environment's return.
        length: environment steps taken.
        switches: goal or skill changes (0 for flat DDPG).
        extra: further scalars by name.
    """

    ret: jax.Array
    env_return: jax.Array
    length: jax.Array
    switches: jax.Array
    extra: dict

    def as_dict(self) -> dict[str, jax.Array]:
        """The engine's flat form (``return``, ``env_return``, ``length``, ``switches``, …)."""
        return {"return": self.ret, "env_return": self.env_return, "length": self.length,
                "switches": self.switches, **self.extra}


class EpisodeAgent(Protocol):
    """What an agent supplies to :func:`run_episode`."""

    env: Environment
    learning_starts: int
    """Environment steps of the random phase at a run's start."""

    def step_keys(self, key: jax.Array, train: bool) -> dict[str, jax.Array]:
        """One step's random streams by name, ``"env"`` among them."""

    def decay(self, state: Any) -> Any:
        """``state`` with the learning rates of its episode count."""

    def begin(self, state: Any, obs: jax.Array, horizon: int, train: bool) -> tuple[Any, dict]:
        """The per-episode state (noise processes, …) and the zero sums."""

    def act(self, state: Any, inner: Any, obs: jax.Array, alive: jax.Array, keys: dict,
            random_phase: jax.Array, env_params: Any, horizon: int,
            train: bool) -> tuple[Any, jax.Array, Any]:
        """``(inner, env_action, info)``: the action given to the environment and what the
        agent needs of this step afterwards (``alive``: the episode has not ended)."""

    def observe(self, state: Any, inner: Any, obs: jax.Array, info: Any, res: Any,
                alive: jax.Array, keys: dict, random_phase: jax.Array, horizon: int,
                train: bool) -> tuple[Any, Any, dict, dict]:
        """``(state, inner, sums to add, trajectory entries)`` of the step's result ``res``:
        its rewards and, in training, storing and learning (nothing where not ``alive``)."""

    def finish(self, state: Any, inner: Any, sums: dict, traj: dict,
               train: bool) -> tuple[Any, EpisodeMetrics]:
        """The state after the episode and its metrics."""


@struct.dataclass
class _Carry:
    agent: Any
    inner: Any
    obs: jax.Array
    env_state: Any
    alive: jax.Array
    sums: dict


def select(pred: jax.Array, new: Any, old: Any) -> Any:
    """``new`` where ``pred``, else ``old``, leaf by leaf."""
    return jax.tree_util.tree_map(lambda n, o: jnp.where(pred, n, o), new, old)


def decay_factor(lr_decay: float, every: int, episodes: jax.Array) -> jax.Array:
    """``lr_decay ** (episodes // every)``: the learning rates' factor in an episode."""
    return jnp.float32(lr_decay) ** (episodes // every).astype(jnp.float32)


def run_episode(agent: EpisodeAgent, key: jax.Array, state: Any, env_params: Any,
                train: bool) -> tuple[Any, EpisodeMetrics, dict]:
    """One episode: ``(state, metrics, trajectory)``; the trajectory's arrays have the
    horizon as leading axis."""
    env, horizon = agent.env, agent.env.max_steps(env_params)
    k_reset, k_steps = jax.random.split(key)
    obs, env_state = env.reset(k_reset, env_params)
    if train:
        state = agent.decay(state)
    inner, sums = agent.begin(state, obs, horizon, train)
    carry = _Carry(agent=state, inner=inner, obs=jnp.asarray(obs, jnp.float32),
                   env_state=env_state, alive=jnp.ones((), bool), sums=sums)

    def step(carry: _Carry, key: jax.Array) -> tuple[_Carry, dict]:
        keys = agent.step_keys(key, train)
        random_phase = carry.agent.env_steps < agent.learning_starts
        inner, action, info = agent.act(carry.agent, carry.inner, carry.obs, carry.alive, keys,
                                        random_phase, env_params, horizon, train)
        res = env.step(keys["env"], carry.env_state, action, env_params)
        alive = carry.alive
        state, inner, adds, out = agent.observe(carry.agent, inner, carry.obs, info, res,
                                                alive, keys, random_phase, horizon, train)
        ended = jnp.asarray(res.terminated, bool) | jnp.asarray(res.truncated, bool)
        sums = {k: v + adds[k] if k in adds else v for k, v in carry.sums.items()}
        new = _Carry(agent=state, inner=inner,
                     obs=jnp.where(alive, jnp.asarray(res.obs, jnp.float32), carry.obs),
                     env_state=select(alive, res.state, carry.env_state),
                     alive=alive & ~ended, sums=sums)
        return new, out

    carry, traj = jax.lax.scan(step, carry, jax.random.split(k_steps, horizon))
    state, metrics = agent.finish(carry.agent, carry.inner, carry.sums, traj, train)
    return state, metrics, traj

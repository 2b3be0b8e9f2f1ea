"""The agent protocol the training engine drives.

An agent is a small frozen object of pure functions built from a config and an environment
(``make_agent(config, env)``). Its whole state — network parameters, optimiser states, replay
buffers, noise states, counters — is one pytree, so that the engine can ``lax.scan`` over
episodes and ``vmap`` over seeds. The engine never looks inside an agent: it calls

* ``init(key, env_params) -> state``
* ``train_episode(key, state, env_params) -> (state, metrics)``: one episode of acting with
  exploration noise, storing transitions and learning (every step / every segment, as the
  algorithm says). ``metrics`` is a flat dict of scalar arrays with at least the keys of
  :data:`EPISODE_KEYS`.
* ``evaluate(key, state, env_params) -> (metrics, trajectory)``: one episode without noise and
  without learning. ``trajectory`` is a dict of arrays with a leading time axis of the task's
  horizon (at least ``obs``, ``action``, ``reward``, ``alive`` — 1 while the episode runs);
  hierarchical agents add ``goal`` and ``switch`` (h-DDPG: ``skill``).

Episodes have the fixed length of the task's horizon inside ``lax.scan``; steps after the
episode ended are masked (no insert, no update, no reward).
"""

from __future__ import annotations

from typing import Any, Protocol

import jax

#: keys every ``train_episode`` / ``evaluate`` metrics dict has.
EPISODE_KEYS = ("return", "env_return", "length", "switches")


class Agent(Protocol):
    """What the training engine needs of an agent (see module docstring)."""

    def init(self, key: jax.Array, env_params: Any) -> Any: ...

    def train_episode(
        self, key: jax.Array, state: Any, env_params: Any
    ) -> tuple[Any, dict[str, jax.Array]]: ...

    def evaluate(
        self, key: jax.Array, state: Any, env_params: Any
    ) -> tuple[dict[str, jax.Array], dict[str, jax.Array]]: ...

"""The high level's duration chosen by its critic (``HIDDPGConfig.duration_choice="argmax"``).

In the paper (``"actor"``) the high level's actor outputs the goal and the duration ``(g, T)``
together and follows the critic's gradient in both. The return is not smooth in ``T``: it
jumps by the switch cost where ``T`` reaches the episode's end, and a good two-goal plan is a
narrow ridge in ``T`` (docs/results.md), so the gradient does not find the switch count.

With ``"argmax"`` the duration is a discrete choice and the goal a continuous parameter of it,
as in parameterised-action Q-learning (P-DQN, Xiong et al. 2018): the actor maps ``[s, τ]``
(``τ`` the duration's unit entry) to a goal ``μ(s, τ)``, the critic scores ``Q([s, τ], g)``,
and at a switch the high level takes the integer duration ``T ∈ {⌈T_min⌉ … ⌊T_max⌋}`` (at most
the steps left) whose goal the critic values most. Its critic's target does the same at the
next switch state, the choice made by the online networks and valued by the target networks
(double Q-learning, against the max's upward bias); the actor learns at durations drawn
uniformly, so that it has a goal for every duration the choice may take. ``D_H`` stores the
duration carried out: ``c = τ(n)``, ``a = g``.

The functions take the :class:`hiddpg.agents.hi_ddpg.HIDDPG` agent; the high level's input
must hold the time left (``high_time_input``), which the target and the actor's durations
read from its last entry.
"""

from __future__ import annotations

import math
from typing import Any

import jax
import jax.numpy as jnp


def candidates(agent: Any, steps_left: jax.Array) -> jax.Array:
    """The integer durations the choice ranges over, ``⌈T_min⌉ … ⌊T_max⌋``, each clipped to
    ``[1, steps_left]`` (float32; a duration past the episode's end is the same as holding
    to it)."""
    c = agent.config
    ts = jnp.arange(math.ceil(c.duration_min), math.floor(c.duration_max) + 1,
                    dtype=jnp.float32)
    return jnp.minimum(ts, jnp.maximum(steps_left, 1).astype(jnp.float32))


def best(agent: Any, actor: Any, critic: Any, hobs: jax.Array, steps_left: jax.Array):
    """``(τ, g, q)`` of the duration whose goal ``μ(hobs, τ)`` the critic values most."""
    taus = agent.duration_unit(candidates(agent, steps_left))
    inputs = jnp.concatenate(
        [jnp.broadcast_to(hobs, (len(taus), hobs.shape[-1])), taus[:, None]], axis=1)
    block = agent.high.block
    goals = block.mu(actor, inputs)
    q = block.q(critic, inputs, goals)
    j = jnp.argmax(q)
    return taus[j], goals[j], q[j]


def random_duration(agent: Any, key: jax.Array, steps_left: jax.Array) -> jax.Array:
    """A duration drawn uniformly from :func:`candidates` (``duration_explore``)."""
    options = candidates(agent, steps_left)
    return options[jax.random.randint(key, (), 0, len(options))]


def explore(agent: Any, high_state: Any, hobs: jax.Array, action: jax.Array,
            steps_left: jax.Array, key: jax.Array) -> jax.Array:
    """``action`` or, with probability ``duration_explore``, a duration drawn by
    :func:`random_duration` (with ``"argmax"``, and the actor's goal for it)."""
    k_use, k_t = jax.random.split(jax.random.fold_in(key, 3))
    tau = agent.duration_unit(random_duration(agent, k_t, steps_left))
    drawn = action.at[agent.goal_dim].set(tau)
    if agent.argmax:
        drawn = jnp.concatenate([agent.high.act(high_state, hobs, tau[None]), tau[None]])
    use = jax.random.uniform(k_use) < agent.config.duration_explore
    return jnp.where(use, drawn, action)


def _steps_left(inputs_time: jax.Array, horizon: int) -> jax.Array:
    return jnp.maximum(jnp.round(inputs_time * horizon), 1.0)


def next_value(agent: Any, horizon: int):
    """The critic target's value of next states ``s2`` (a batch of high-level inputs):
    the duration chosen by the online networks, its goal and value from the target ones."""

    def value(block: Any, block_state: Any, s2: jax.Array) -> jax.Array:
        def one(x: jax.Array, left: jax.Array) -> jax.Array:
            tau, _, _ = best(agent, block_state.actor, block_state.critic, x, left)
            inp = jnp.concatenate([x, tau[None]])
            return block.q(block_state.target_critic, inp, block.mu(block_state.target_actor,
                                                                    inp))

        return jax.vmap(one)(s2, _steps_left(s2[:, -1], horizon))

    return value


def actor_inputs(agent: Any, horizon: int):
    """The actor's batch ``[s, τ]`` with ``τ`` redrawn uniformly from each state's
    :func:`candidates` (``s``'s last entry is the time left)."""

    def redraw(key: jax.Array, inputs: jax.Array) -> jax.Array:
        left = _steps_left(inputs[:, -2], horizon)
        keys = jax.random.split(key, inputs.shape[0])
        t = jax.vmap(lambda k, n: random_duration(agent, k, n))(keys, left)
        return inputs.at[:, -1].set(agent.duration_unit(t))

    return redraw

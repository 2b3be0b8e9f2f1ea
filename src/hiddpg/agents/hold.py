"""Holding the goal to the episode's end (``HIDDPGConfig.hold_choice``, ``hold_explore``).

The return is not smooth in the duration ``T``: it jumps by the switch cost where ``T`` reaches
the episode's end, so the policy gradient does not find "no more switches" (docs/results.md).
``hold_choice`` lets the high critic compare, at a switch, the actor's ``(g, T)`` with ``(g,
hold to the end)`` and take the better; ``hold_explore`` holds at random during training so
that ``D_H`` has such segments from every switch state.

The function takes the :class:`hiddpg.agents.hi_ddpg.HIDDPG` agent (like
:mod:`hiddpg.agents.durations`).
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp


def hold(agent: Any, state: Any, hobs: jax.Array, action: jax.Array, steps_left: jax.Array,
         key: jax.Array, train: bool, free: jax.Array) -> jax.Array:
    """``action`` (a unit ``(g, T)``) or, where chosen, its goal held to the episode's end
    (``T`` = the steps left, at most ``T_max``): with ``hold_choice`` when the high critic
    values that higher, with ``hold_explore`` (training) at random; only where ``free`` (not
    a random phase)."""
    c = agent.config
    hold_t = jnp.minimum(steps_left, c.duration_max).astype(jnp.float32)
    held = action.at[agent.goal_dim].set(agent.duration_unit(hold_t))
    use = jnp.array(False)
    if c.hold_choice:
        critic = state.high.block.critic
        q = lambda a: agent.high.block.q(critic, hobs, a)  # noqa: E731
        use = q(held) > q(action)
    if train and c.hold_explore > 0:
        use = use | (jax.random.uniform(jax.random.fold_in(key, 7)) < c.hold_explore)
    return jnp.where(use & free, held, action)

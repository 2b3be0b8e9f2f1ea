"""Holding the goal to the episode's end (:class:`~hiddpg.configs.HoldChoice`).

The return is not smooth in the duration ``T``: it jumps by the switch cost where ``T`` reaches
the episode's end, so the policy gradient does not find "no more switches". At a switch the
high critic compares the actor's ``(g, T)`` with ``(g, hold to the end)`` and takes the better;
in training a fraction ``explore`` of switches holds at random, so that ``D_H`` has such
segments from every switch state. The high level sees the fraction of the episode left.
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp

from hiddpg.agents.choice import Chooser
from hiddpg.agents.level import LevelState


@dataclasses.dataclass(frozen=True)
class HoldChooser(Chooser):
    """The actor's ``(g, T)`` or ``g`` held to the end, whichever the critic values more."""

    time_input = True

    def settle(self, state: LevelState, hobs: jax.Array, action: jax.Array,
               steps_left: jax.Array, key: jax.Array, train: bool,
               free: jax.Array) -> jax.Array:
        """``action`` or its goal held to the end (``T`` = the steps left, at most ``T_max``),
        where the critic values that more or, in training, at random; only where ``free``."""
        hold_t = jnp.minimum(steps_left, self.duration_max).astype(jnp.float32)
        held = action.at[self.goal_dim].set(self.duration_unit(hold_t))
        use = self.q(state, hobs, held) > self.q(state, hobs, action)
        if train and self.config.explore > 0:
            use = use | (jax.random.uniform(key) < self.config.explore)
        return jnp.where(use & free, held, action)

"""The low level's intrinsic reward (spec §2): ``r_int = -|P (s' - g)|_2``, ``P`` selecting the
goal entries; with a :class:`~hiddpg.configs.RestTerm` of weight ``w`` also the entries a goal
does not fix (the velocities, 0 in the paper's goal state), ``-|(P (s' - g), w R s')|_2``."""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp

from hiddpg.configs import RestTerm
from hiddpg.envs.base import GoalSpace


@dataclasses.dataclass(frozen=True)
class IntrinsicReward:
    """``reward(next_obs, goal)`` for one step (goal: the full goal vector)."""

    goal_space: GoalSpace
    obs_dim: int
    rest: RestTerm | None = None

    def __call__(self, next_obs: jax.Array, goal: jax.Array) -> jax.Array:
        space = self.goal_space
        error = space.select(next_obs) - space.select(goal)
        if self.rest is not None and self.rest.weight > 0:
            rest = jnp.asarray([i for i in range(self.obs_dim) if i not in space.indices])
            error = jnp.concatenate([error, self.rest.weight * next_obs[rest]])
        return -jnp.linalg.norm(error)

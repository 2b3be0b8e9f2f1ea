"""The Huber loss for a level's critic and its schedule (:class:`~hiddpg.configs.HuberLoss`).

Squared within ``δ`` of the target and linear beyond, it lets rare large TD errors (the arm's
collisions, reward -100) pull a critic's values less than the many small ones near the target;
a large ``δ`` first and a small one later (``late_delta``) keeps the collisions' cost while the
detour is learned, then fits the small returns near the target precisely [decision].

[decision] marks a value of ours where the paper is silent; docs/deviations.md (each with the
paper's value and why) lists them.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp

from hiddpg.configs import HuberLoss


def delta_at(config: HuberLoss, episode: Any) -> jax.Array | float:
    """``δ`` in episode ``episode`` (the agent's count, from 0)."""
    if config.late_delta <= 0:
        return config.delta
    late = jnp.asarray(episode) >= config.late_episode
    return jnp.where(late, config.late_delta, config.delta)

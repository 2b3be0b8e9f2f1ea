"""More high-level learning than Alg. 1's (:class:`~hiddpg.configs.EagerHighLevel`): under the
seed ``vmap`` the masked high-level update is computed at every step anyway, so updating at
every step gives about ``T`` times more updates for the same compute; the pre-training's random
segments give ``D_H`` a broad sample of goals from the start [decision].

[decision] marks a value of ours where the paper is silent; docs/deviations.md (each with the
paper's value and why) lists them."""

from __future__ import annotations

import jax

from hiddpg.configs import EagerHighLevel


def high_update_due(config: EagerHighLevel | None, seg_end: jax.Array,
                    alive: jax.Array) -> jax.Array:
    """Whether this step brings a high-level update: a segment's end (Alg. 1 lines 16-20), or
    every step of the episode."""
    return alive if config is not None and config.every_step else seg_end


def stores_segment(config: EagerHighLevel | None, pretrain: jax.Array) -> jax.Array:
    """Whether ``D_H`` takes this episode's segments: not in pre-training (Alg. 1), or always."""
    return ~pretrain | (config is not None and config.pretraining_segments)

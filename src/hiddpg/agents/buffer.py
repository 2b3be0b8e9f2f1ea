"""A circular replay buffer as a pytree (the replay memory ``D`` of paper Alg. 1, lines 2, 9, 14).

The buffer stores any pytree of transitions (a dict of arrays, typically ``obs``, ``action``,
``reward``, ``next_obs``, ``terminated``): every leaf gets a leading ``capacity`` axis. Inserts
overwrite the oldest entry once the buffer is full; sampling is uniform with replacement over
the filled part (spec §1). All functions are pure, ``jit``- and ``vmap``-safe: ``add`` takes a
boolean ``mask`` so that masked steps (after the episode ended, or steps without a high-level
switch) leave the buffer bitwise unchanged without Python branching.

Example::

    buf = buffer.init({"obs": jnp.zeros(4), "reward": jnp.zeros(())}, capacity=10_000)
    buf = buffer.add(buf, {"obs": obs, "reward": r}, mask=alive)
    batch = buffer.sample(buf, key, 64)        # {"obs": (64, 4), "reward": (64,)}
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
from flax import struct


@struct.dataclass
class ReplayBuffer:
    """Circular buffer state.

    Attributes:
        data: pytree of arrays, each with leading axis ``capacity``.
        pos: int32 index of the next slot to write.
        size: int32 number of filled slots (``<= capacity``).
    """

    data: Any
    pos: jax.Array
    size: jax.Array

    @property
    def capacity(self) -> int:
        """The static capacity (leading axis of the data leaves)."""
        return jax.tree_util.tree_leaves(self.data)[0].shape[0]


def init(example: Any, capacity: int) -> ReplayBuffer:
    """An empty buffer for transitions shaped like ``example`` (a pytree of arrays)."""
    if not (isinstance(capacity, int) and capacity > 0):
        raise ValueError(f"capacity={capacity!r} must be a positive int")
    data = jax.tree_util.tree_map(
        lambda x: jnp.zeros((capacity,) + jnp.shape(x), jnp.asarray(x).dtype), example
    )
    zero = jnp.zeros((), jnp.int32)
    return ReplayBuffer(data=data, pos=zero, size=zero)


def add(buffer: ReplayBuffer, transition: Any, mask: jax.Array | bool = True) -> ReplayBuffer:
    """Insert one transition at ``pos`` if ``mask`` is true; otherwise return the buffer unchanged.

    The slot is rewritten with ``where(mask, new, old)``, which copies bits, so a masked insert
    is bitwise a no-op.
    """
    mask = jnp.asarray(mask, bool)
    pos = buffer.pos

    def write(store: jax.Array, x: jax.Array) -> jax.Array:
        x = jnp.asarray(x, store.dtype)
        return store.at[pos].set(jnp.where(mask, x, store[pos]))

    data = jax.tree_util.tree_map(write, buffer.data, transition)
    capacity = buffer.capacity
    new_pos = jnp.where(mask, (pos + 1) % capacity, pos).astype(jnp.int32)
    new_size = jnp.where(mask, jnp.minimum(buffer.size + 1, capacity), buffer.size)
    return ReplayBuffer(data=data, pos=new_pos, size=new_size.astype(jnp.int32))


def sample(buffer: ReplayBuffer, key: jax.Array, batch_size: int) -> Any:
    """``batch_size`` transitions drawn uniformly with replacement from the filled slots.

    On an empty buffer this returns copies of slot 0 (zeros); callers gate their updates.
    """
    high = jnp.maximum(buffer.size, 1)
    idx = jax.random.randint(key, (batch_size,), 0, high)
    return jax.tree_util.tree_map(lambda store: store[idx], buffer.data)

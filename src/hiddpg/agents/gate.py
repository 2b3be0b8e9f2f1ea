"""Updates that run only on some steps, kept as real branches when seeds are vmapped.

Every agent skips its update on some steps (before ``learning_starts``, after the episode ended,
between HI-DDPG's segment ends). ``lax.cond`` does that for one run, but ``vmap`` over seeds
turns a ``cond`` with a per-seed predicate into a ``select`` that computes *both* branches on
every step: the update is paid for even when no seed wants it.

:func:`gated` keeps the branch. The engine vmaps over seeds with the axis name
:data:`SEED_AXIS`; inside it the predicate is reduced over the seeds (``psum``), which gives an
unbatched "how many seeds update?" that ``vmap`` leaves as a real branch: none (skip), all
(update, nothing to select), or some (compute every seed's update and keep it only where the
seed's own predicate holds). Each seed's result is exactly what a plain ``cond`` gives it.
Outside a vmap named :data:`SEED_AXIS` (one run, ``jax.vmap`` without the name) it is a plain
``lax.cond``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

import jax
import jax.numpy as jnp
from jax import lax

#: the axis name under which the engine vmaps over seeds (:mod:`hiddpg.train`).
SEED_AXIS = "seeds"

T = TypeVar("T")


def seed_axis_bound() -> bool:
    """Whether the code is traced inside ``vmap(..., axis_name=SEED_AXIS)``."""
    try:
        lax.axis_index(SEED_AXIS)
    except NameError:
        return False
    return True


def gated(pred: jax.Array, update: Callable[[Any], T], skip: Callable[[Any], T],
          operand: Any) -> T:
    """``update(operand)`` where ``pred`` holds, ``skip(operand)`` elsewhere.

    ``update`` and ``skip`` must return pytrees of the same structure, shapes and dtypes (as for
    ``lax.cond``). Under the named seed vmap the update is computed only on steps where at least
    one seed needs it.
    """
    if not seed_axis_bound():
        return lax.cond(pred, update, skip, operand)

    def masked(x: Any) -> T:
        new, old = update(x), skip(x)
        return jax.tree.map(lambda a, b: jnp.where(pred, a, b), new, old)

    count = lax.psum(jnp.asarray(pred, jnp.int32), SEED_AXIS)
    n_seeds = lax.psum(1, SEED_AXIS)
    # 0: no seed updates; 1: some do (update, keep per seed); 2: all do (no select needed)
    branch = (count > 0).astype(jnp.int32) + (count == n_seeds).astype(jnp.int32)
    return lax.switch(branch, (skip, masked, update), operand)

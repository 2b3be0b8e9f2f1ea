"""The one transition type: what an agent stores in its replay buffer and what a DDPG block
learns from (a minibatch is a :class:`Transition` with a leading batch axis)."""

from __future__ import annotations

import jax
import jax.numpy as jnp
from flax import struct


@struct.dataclass
class Transition:
    """``(s, c, a, r, s', terminated)`` of one step (or, for HI-DDPG's high level, one segment).

    Attributes:
        obs: the state ``s`` the action was chosen in.
        context: what the actor sees besides ``s``: the low level's goal ``g``, the duration of
            the critic-chosen durations; an empty vector otherwise.
        action: the action in the unit box (h-DDPG's meta-critic: the skill's index).
        reward: ``r``.
        next_obs: the next state ``s'``.
        terminated: True where the value does not bootstrap from ``s'``.
        episode, steps_left: the agent's episode count and the steps left in the episode
            after this one, for hindsight goals (:mod:`hiddpg.agents.hindsight`); None
            without them.
    """

    obs: jax.Array
    context: jax.Array
    action: jax.Array
    reward: jax.Array
    next_obs: jax.Array
    terminated: jax.Array
    episode: jax.Array | None = None
    steps_left: jax.Array | None = None

    @property
    def inputs(self) -> jax.Array:
        """The actor's and critic's input ``[s, c]``."""
        return jnp.concatenate([self.obs, self.context], axis=-1)

    @property
    def next_inputs(self) -> jax.Array:
        """``[s', c]``: the context is kept to the next state."""
        return jnp.concatenate([self.next_obs, self.context], axis=-1)


def example(obs_dim: int, action_dim: int, context_dim: int = 0,
            hindsight: bool = False) -> Transition:
    """A zero transition of these sizes (the shape a replay buffer is made for)."""
    z = lambda n: jnp.zeros((n,), jnp.float32)  # noqa: E731
    counters = ({"episode": jnp.zeros((), jnp.int32), "steps_left": jnp.zeros((), jnp.int32)}
                if hindsight else {})
    return Transition(obs=z(obs_dim), context=z(context_dim), action=z(action_dim),
                      reward=jnp.zeros((), jnp.float32), next_obs=z(obs_dim),
                      terminated=jnp.zeros((), bool), **counters)

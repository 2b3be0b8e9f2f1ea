"""Hindsight: goals for the low level (the "future" strategy of Andrychowicz et al. 2017, HER)
and actions for the high level (the hindsight action transitions of Levy et al. 2019, HAC).

The low level learns to reach goals; every stretch of its experience also shows how to reach
the states it passed through. With :class:`Hindsight`, a fraction of each minibatch drawn from
``D_L`` has its goal replaced by the goal entries ``P s'`` of a state reached later in the same
episode (offset drawn uniformly from the steps left in the episode, the transition's own next
state included), and its reward recomputed for that goal. The goals the high level sets are
few and concentrated; relabelled goals lie all along the paths the puck or the arm took, many
of them close, so the low level sees how to finish a reach precisely [decision; the paper
leaves the low level's learning open: "we omit the low-level learning algorithm due to its
similarity with the basic DDPG"].

For the high level, :func:`reached_action` stores a segment in ``D_H`` as if its goal had been
the one its low level reached (the goal entries of the segment's last state): the high critic
then learns what a goal leads to where the low level really gets there, and the cost of an
overshoot that still arrives is charged to where it arrived; HI-DDPG keeps the goal set for
a segment that ended the episode by a collision, so that the goals that lead into the obstacle
stay charged with it [decision].

Bookkeeping (low level): transitions carry ``episode`` (the agent's episode counter) and
``steps_left`` (steps left in the episode after this one, by the time limit). The buffer is
written in time order per agent, so the transition ``k`` slots after slot ``i`` is ``k`` steps
later in the same episode if its ``episode`` matches; where it does not (the episode ended
early, by a collision, or the slot was not written yet), the transition keeps offset 0: its own
next state as the goal.

[decision] marks a value of ours where the paper is silent; docs/deviations.md (each with the
paper's value and why) lists them.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp

from hiddpg.agents.buffer import ReplayBuffer
from hiddpg.agents.transition import Transition
from hiddpg.configs import ActionHindsight
from hiddpg.envs.base import GoalSpace


@dataclasses.dataclass(frozen=True)
class Hindsight:
    """Relabel a fraction of the low level's minibatch with goals reached later.

    Attributes:
        fraction: probability that a sampled transition gets a hindsight goal.
        goal_space: which state entries a goal fixes (:class:`GoalSpace`).
        obs_dim: size of the full goal vector.
        reward: ``(s2, goal) -> r_int`` for one transition.
    """

    fraction: float
    goal_space: GoalSpace
    obs_dim: int
    reward: Callable[[jax.Array, jax.Array], jax.Array]

    def sample(self, buf: ReplayBuffer, key: jax.Array, batch_size: int) -> Transition:
        """A uniform minibatch of ``buf`` with hindsight goals in about ``fraction`` of it."""
        k_idx, k_use, k_off = jax.random.split(key, 3)
        capacity = buf.capacity
        idx = jax.random.randint(k_idx, (batch_size,), 0, jnp.maximum(buf.size, 1))
        tr = jax.tree_util.tree_map(lambda store: store[idx], buf.data)
        newer = jnp.mod(buf.pos - 1 - idx, capacity)  # slots written after idx
        span = jnp.minimum(tr.steps_left, newer)
        offset = jnp.floor(jax.random.uniform(k_off, (batch_size,)) * (span + 1))
        j = jnp.mod(idx + offset.astype(jnp.int32), capacity)
        same = buf.data.episode[j] == tr.episode
        j = jnp.where(same, j, idx)
        reached = self.goal_space.embed(self.goal_space.select(buf.data.next_obs[j]),
                                        self.obs_dim)
        use = jax.random.uniform(k_use, (batch_size,)) < self.fraction
        goal = jnp.where(use[:, None], reached, tr.context)
        reward = jax.vmap(self.reward)(tr.next_obs, reached)
        return tr.replace(context=goal, reward=jnp.where(use, reward, tr.reward))


def reached_action(goal_space: GoalSpace, action: jax.Array, last_obs: jax.Array,
                   use: jax.Array) -> jax.Array:
    """The high-level unit action with its goal entries (the first ``goal_space.dim``)
    replaced, where ``use``, by the goal entries of ``last_obs``, unit-scaled and clipped to
    the box; the other entries (the duration) are kept."""
    reached = jnp.clip(goal_space.unscale(goal_space.select(last_obs)), -1.0, 1.0)
    gd = goal_space.dim
    return action.at[:gd].set(jnp.where(use, reached, action[:gd]))


def high_relabel(config: ActionHindsight | None, goal_space: GoalSpace):
    """``(action, step result, key) -> action`` that ``D_H`` stores for a segment ending with
    that step: with probability ``config.probability`` the goal reached (:func:`reached_action`)
    unless the step terminated the episode; the action itself without ``config``."""
    if config is None:
        return lambda action, res, key: action

    def relabel(action: jax.Array, res: Any, key: jax.Array) -> jax.Array:
        use = (jax.random.uniform(key) < config.probability) & ~res.terminated
        return reached_action(goal_space, action, res.obs, use)

    return relabel

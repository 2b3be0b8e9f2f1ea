"""The high level's duration chosen by its critic (:class:`~hiddpg.configs.CriticDurations`).

In the paper the high level's actor outputs the goal and the duration ``(g, T)``
together and follows the critic's gradient in both. The return is not smooth in ``T``: it
jumps by the switch cost where ``T`` reaches the episode's end, and a good two-goal plan is a
narrow ridge in ``T``, so the gradient does not find the switch count.

Here the duration is a discrete choice and the goal a continuous parameter of it,
as in parameterised-action Q-learning (P-DQN, Xiong et al. 2018): the actor maps ``[s, τ]``
(``τ`` the duration's unit entry) to a goal ``μ(s, τ)``, the critic scores ``Q([s, τ], g)``,
and at a switch the high level takes the integer duration ``T ∈ {⌈T_min⌉ … ⌊T_max⌋}`` (at most
the steps left) whose goal the critic values most. Its critic's target does the same at the
next switch state, the choice made by the online networks and valued by the target networks
(double Q-learning, against the max's upward bias); the actor learns at durations drawn
uniformly, so that it has a goal for every duration the choice may take. ``D_H`` stores the
duration carried out: ``c = τ(n)``, ``a = g``. The high level's input holds the fraction of the
episode left (its last entry, read by the target and the actor's durations); it has no dynamics
model, which would not see ``T``. In training a fraction ``explore`` of switches draws the
duration uniformly, with the actor's goal for it.
"""

from __future__ import annotations

import dataclasses
import math

import jax
import jax.numpy as jnp

from hiddpg.agents.choice import Chooser
from hiddpg.agents.level import Level, LevelState


@dataclasses.dataclass(frozen=True)
class DurationChooser(Chooser):
    """The critic picks the integer duration; the actor maps ``(s, τ)`` to its goal."""

    time_input = True

    @property
    def level(self) -> Level:
        """Input ``s``, context ``τ``, action ``g``; no model."""
        return Level(config=self.level_config, state_dim=self.obs_dim + 1, context_dim=1,
                     action_dim=self.goal_dim, time_scale=1.0, model_weight=0.0,
                     use_model=False)

    def candidates(self, steps_left: jax.Array) -> jax.Array:
        """The integer durations the choice ranges over, ``⌈T_min⌉ … ⌊T_max⌋``, each clipped
        to ``[1, steps_left]`` (float32; a duration past the episode's end is the same as
        holding to it)."""
        ts = jnp.arange(math.ceil(self.duration_min), math.floor(self.duration_max) + 1,
                        dtype=jnp.float32)
        return jnp.minimum(ts, jnp.maximum(steps_left, 1).astype(jnp.float32))

    def best(self, actor, critic, hobs: jax.Array, steps_left: jax.Array):
        """``(τ, g, q)`` of the duration whose goal ``μ(hobs, τ)`` the critic values most."""
        taus = self.duration_unit(self.candidates(steps_left))
        inputs = jnp.concatenate(
            [jnp.broadcast_to(hobs, (len(taus), hobs.shape[-1])), taus[:, None]], axis=1)
        block = self.level.block
        goals = block.mu(actor, inputs)
        q = block.q(critic, inputs, goals)
        j = jnp.argmax(q)
        return taus[j], goals[j], q[j]

    def random_duration(self, key: jax.Array, steps_left: jax.Array) -> jax.Array:
        """A duration drawn uniformly from :meth:`candidates`."""
        options = self.candidates(steps_left)
        return options[jax.random.randint(key, (), 0, len(options))]

    # -- choosing -----------------------------------------------------------------------------
    def propose(self, state: LevelState, hobs: jax.Array, steps_left: jax.Array) -> jax.Array:
        tau, goal, _ = self.best(state.block.actor, state.block.critic, hobs, steps_left)
        return jnp.concatenate([goal, tau[None]])

    def explore(self, state: LevelState, hobs: jax.Array, action: jax.Array, noise: jax.Array,
                steps_left: jax.Array, key: jax.Array) -> jax.Array:
        """With probability ``explore`` a uniformly drawn duration and the actor's goal for it;
        noise on the goal only (the duration is a choice, not a noisy output)."""
        if self.config.explore > 0:
            k_use, k_t = jax.random.split(key)
            tau = self.duration_unit(self.random_duration(k_t, steps_left))
            drawn = jnp.concatenate([self.level.act(state, hobs, tau[None]), tau[None]])
            use = jax.random.uniform(k_use) < self.config.explore
            action = jnp.where(use, drawn, action)
        return jnp.clip(action + noise.at[self.goal_dim].set(0.0), -1.0, 1.0)

    # -- storing and learning -----------------------------------------------------------------
    def carried(self, action: jax.Array, n: jax.Array) -> jax.Array:
        """The duration entry becomes the ``n`` steps carried out."""
        return action.at[self.goal_dim].set(self.duration_unit(n.astype(jnp.float32)))

    def stored(self, action: jax.Array) -> tuple[jax.Array, jax.Array]:
        return action[self.goal_dim:], action[: self.goal_dim]

    def q(self, state: LevelState, hobs: jax.Array, action: jax.Array) -> jax.Array:
        inputs = jnp.concatenate([hobs, action[self.goal_dim:]], axis=-1)
        return self.level.block.q(state.block.critic, inputs, action[: self.goal_dim])

    def update(self, state: LevelState, key: jax.Array, do: jax.Array, *,
               episode: jax.Array, horizon: int) -> tuple[LevelState, dict]:
        """The target's next value and the actor's durations as the module docstring says."""
        return self.level.maybe_update(state, key, do, episode=episode,
                                       next_value=self.next_value(horizon),
                                       actor_inputs=self.actor_inputs(horizon))

    def next_value(self, horizon: int):
        """The critic target's value of next states ``s2`` (a batch of high-level inputs):
        the duration chosen by the online networks, its goal and value from the target ones."""

        def value(block, block_state, s2: jax.Array) -> jax.Array:
            def one(x: jax.Array, left: jax.Array) -> jax.Array:
                tau, _, _ = self.best(block_state.actor, block_state.critic, x, left)
                inp = jnp.concatenate([x, tau[None]])
                return block.q(block_state.target_critic, inp,
                               block.mu(block_state.target_actor, inp))

            return jax.vmap(one)(s2, _steps_left(s2[:, -1], horizon))

        return value

    def actor_inputs(self, horizon: int):
        """The actor's batch ``[s, τ]`` with ``τ`` redrawn uniformly from each state's
        :meth:`candidates` (``s``'s last entry is the time left)."""

        def redraw(key: jax.Array, inputs: jax.Array) -> jax.Array:
            left = _steps_left(inputs[:, -2], horizon)
            keys = jax.random.split(key, inputs.shape[0])
            t = jax.vmap(self.random_duration)(keys, left)
            return inputs.at[:, -1].set(self.duration_unit(t))

        return redraw


def _steps_left(inputs_time: jax.Array, horizon: int) -> jax.Array:
    return jnp.maximum(jnp.round(inputs_time * horizon), 1.0)

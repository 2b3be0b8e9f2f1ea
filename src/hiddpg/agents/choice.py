"""How HI-DDPG's high level chooses goal and duration at a switch: the protocol, and the
paper's implementation (the actor outputs ``(g, T)``, Alg. 1 line 7).

The high level's action is a unit vector ``(goal entries, T)``: the goal entries are ``tanh``
scaled to the environment's goal bounds (other entries of the goal state 0), ``T`` to
``[T_min, T_max]``. A chooser owns the high level's networks (:attr:`Chooser.level`), what it
sees (:meth:`Chooser.inputs`), how it picks and explores an action, what ``D_H`` stores and how
the level learns. Our alternatives — holding the goal to the end (:mod:`hiddpg.agents.hold`)
and the critic's duration (:mod:`hiddpg.agents.durations`) — override parts of it; the config
selects one by its type (:data:`CHOOSERS`).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import jax
import jax.numpy as jnp

from hiddpg.agents.level import Level, LevelState
from hiddpg.configs import HIDDPGConfig
from hiddpg.envs.base import GoalSpace, affine_unit


@dataclasses.dataclass(frozen=True)
class Chooser:
    """The paper's high-level choice: ``(g, T) = μ_H(s)``, explored by adding noise."""

    config: Any
    level_config: Any
    obs_dim: int
    goal_space: GoalSpace
    duration_min: float
    duration_max: float
    model_weight: float
    use_model: bool
    model_masked: bool = True

    time_input = False
    """Whether the high level also sees the fraction of the episode left."""

    @property
    def goal_dim(self) -> int:
        return self.goal_space.dim

    @property
    def level(self) -> Level:
        """The high level: input ``s``, action ``(g, T)``, the model-based gradient."""
        return Level(config=self.level_config, state_dim=self.obs_dim + int(self.time_input),
                     context_dim=0, action_dim=self.goal_dim + 1, time_scale=1.0,
                     model_weight=self.model_weight, use_model=self.use_model,
                     model_masked=self.model_masked)

    # -- the action's meaning -----------------------------------------------------------------
    def decode(self, action: jax.Array) -> tuple[jax.Array, jax.Array]:
        """Unit action → (full goal vector, continuous duration ``T``)."""
        space = self.goal_space
        goal = space.embed(space.scale(action[: self.goal_dim]), self.obs_dim)
        return goal, affine_unit(action[self.goal_dim], self.duration_min, self.duration_max)

    def duration_unit(self, duration: jax.Array) -> jax.Array:
        """Inverse of :meth:`decode`'s duration map: ``T`` → the unit action entry."""
        return (2.0 * (duration - self.duration_min) / (self.duration_max - self.duration_min)
                - 1.0)

    def inputs(self, obs: jax.Array, steps_left: jax.Array, horizon: int) -> jax.Array:
        """The high level's input: ``obs`` (with :attr:`time_input`, and ``steps_left /
        horizon``)."""
        if not self.time_input:
            return obs
        return jnp.concatenate([obs, (steps_left / horizon)[None].astype(obs.dtype)])

    # -- choosing -----------------------------------------------------------------------------
    def propose(self, state: LevelState, hobs: jax.Array, steps_left: jax.Array) -> jax.Array:
        """The noise-free ``(g, T)``: the actor's output."""
        return self.level.act(state, hobs, jnp.zeros((0,)))

    def explore(self, state: LevelState, hobs: jax.Array, action: jax.Array, noise: jax.Array,
                steps_left: jax.Array, key: jax.Array) -> jax.Array:
        """The proposal with exploration noise, in the unit box."""
        return jnp.clip(action + noise, -1.0, 1.0)

    def settle(self, state: LevelState, hobs: jax.Array, action: jax.Array,
               steps_left: jax.Array, key: jax.Array, train: bool,
               free: jax.Array) -> jax.Array:
        """The action taken, given the explored one (``free``: not a random phase)."""
        return action

    def policy(self, state: LevelState, hobs: jax.Array, steps_left: jax.Array) -> jax.Array:
        """The noise-free action taken at a switch (what an evaluation episode does)."""
        return self.settle(state, hobs, self.propose(state, hobs, steps_left), steps_left,
                           jax.random.PRNGKey(0), False, jnp.array(True))

    # -- storing and learning -----------------------------------------------------------------
    def carried(self, action: jax.Array, n: jax.Array) -> jax.Array:
        """The action as carried out (``n`` steps) and stored in ``D_H``."""
        return action

    def stored(self, action: jax.Array) -> tuple[jax.Array, jax.Array]:
        """``(context, action)`` of ``D_H``'s transition."""
        return jnp.zeros((0,)), action

    def q(self, state: LevelState, hobs: jax.Array, action: jax.Array) -> jax.Array:
        """The high critic's value of the unit action ``(g, T)`` at input ``hobs``."""
        return self.level.block.q(state.block.critic, hobs, action)

    def update(self, state: LevelState, key: jax.Array, do: jax.Array, *,
               episode: jax.Array, horizon: int) -> tuple[LevelState, dict]:
        """One high-level update where ``do`` (Alg. 1 lines 16-20)."""
        return self.level.maybe_update(state, key, do, episode=episode)


def make_chooser(config: HIDDPGConfig, obs_dim: int, goal_space: GoalSpace) -> Chooser:
    """The chooser ``config.choice`` names."""
    from hiddpg.agents.durations import DurationChooser
    from hiddpg.agents.hold import HoldChooser

    choosers = {"actor": Chooser, "hold": HoldChooser, "critic-durations": DurationChooser}
    cls = choosers[config.choice.kind]
    return cls(config=config.choice, level_config=config.high, obs_dim=obs_dim,
               goal_space=goal_space, duration_min=config.duration_min,
               duration_max=config.duration_max, model_weight=config.model_weight,
               use_model=config.use_model, model_masked=config.model_masked)

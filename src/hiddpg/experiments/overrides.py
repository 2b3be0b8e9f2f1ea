"""Policy overrides for diagnostics: HI-DDPG agents with one piece replaced, so that what the
high level learns can be told apart from what the low level does. The agent itself knows
nothing of them; pass one to :class:`hiddpg.train.Trainer` as ``override``. Overrides compose:
each one subclasses the agent's own class (an agent already overridden stays so)."""

from __future__ import annotations

import dataclasses
import functools
from typing import Any

import jax
import jax.numpy as jnp

from hiddpg.agents.hi_ddpg import HIDDPG
from hiddpg.agents.level import zero_metrics


class _ReferenceLowLevel:
    """The environment's own goal-reaching controller (the puck's LQR reference controller,
    spec §1.1) acts in place of the learned low level, noise-free, also in the random phase;
    the low level learns nothing."""

    def low_policy(self, low: Any, obs: jax.Array, goal: jax.Array,
                   env_params: Any) -> jax.Array:
        return self.env.reference_controller(obs, goal, env_params)

    def low_explore(self, action: jax.Array, noise_state: Any, keys: dict,
                    random_phase: jax.Array, episodes: jax.Array):
        return action, noise_state

    def low_update(self, low: Any, key: jax.Array, do: jax.Array, episode: jax.Array):
        return low, zero_metrics()


class _FirstAction:
    """The high level's first choice of an episode replaced by ``first`` (a unit ``(g, T)``);
    the later ones are its own."""

    def choose(self, state: Any, seg: Any, hobs: jax.Array, steps_left: jax.Array,
               keys: dict, noise_eps: jax.Array | None, random: jax.Array) -> jax.Array:
        action = super().choose(state, seg, hobs, steps_left, keys, noise_eps, random)
        return jnp.where(seg.n_goals == 0, self.first, action)


@functools.cache
def _overridden(mixin: type, base: type, fields: tuple[str, ...] = ()) -> type:
    """``base`` with ``mixin``'s methods, as a frozen dataclass with ``fields`` added."""
    return dataclasses.make_dataclass(
        f"{mixin.__name__.lstrip('_')}{base.__name__}",
        [(f, Any, dataclasses.field(default=None)) for f in fields],
        bases=(mixin, base), frozen=True, namespace={"__doc__": mixin.__doc__})


def _check(agent: Any, what: str) -> None:
    if not isinstance(agent, HIDDPG):
        raise ValueError(f"{what} replaces HI-DDPG's, not {type(agent).__name__}'s")


def reference_low_level(agent: HIDDPG) -> HIDDPG:
    """``agent`` with the environment's reference controller as its low level."""
    _check(agent, "the reference low level")
    if not hasattr(agent.env, "reference_controller"):
        raise ValueError(f"{agent.env!r} has no reference_controller (the PuckWorld tasks "
                         "have one); the reference low level cannot run on it")
    return _overridden(_ReferenceLowLevel, type(agent))(agent.config, agent.env)


def with_first_action(agent: HIDDPG, first: jax.Array) -> HIDDPG:
    """``agent`` whose first high-level action is ``first`` (may be traced)."""
    _check(agent, "a given first action")
    cls = _overridden(_FirstAction, type(agent), ("first",))
    extra = {f.name: getattr(agent, f.name) for f in dataclasses.fields(agent)
             if f.name not in ("config", "env", "first")}
    return cls(agent.config, agent.env, first=first, **extra)

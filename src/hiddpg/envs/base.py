"""The functional environment protocol shared by every hiddpg environment.

An environment is split in three, following gymnax:

* a *static* description (:class:`Environment` subclass instance): sizes, horizon, time step,
  goal space. It holds no arrays that change and is hashable, so it can be closed over by
  ``jax.jit``;
* *params* (a ``flax.struct.dataclass`` pytree): every physical constant of the spec, so that
  ``jax.vmap`` over params works; Python-level choices that change array shapes or control flow
  are ``struct.field(pytree_node=False)``;
* *state* (a ``flax.struct.dataclass`` pytree) with at least ``x`` (the physical state vector)
  and ``t`` (the number of actions taken in this episode).

All methods are pure functions of their arguments: ``reset(key, params)`` and
``step(key, state, action, params)`` can be jitted, vmapped and differentiated.

Actions are given in the *normalised* action box ``[action_low, action_high]`` (``[-1, 1]`` for
the puck, ``[0, 1]`` for muscle activations); the core clips to that box and rescales.
"""

from __future__ import annotations

import dataclasses
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp


class StepResult(NamedTuple):
    """What :meth:`Environment.step` returns."""

    obs: jax.Array
    state: Any
    reward: jax.Array
    terminated: jax.Array
    truncated: jax.Array
    info: dict[str, jax.Array]


@dataclasses.dataclass(frozen=True)
class GoalSpace:
    """Which observation entries a hierarchical agent's goal fixes, and their bounds.

    A goal is a vector of the observation's shape; the entries at ``indices`` are free and lie in
    ``[low, high]``, all other entries are 0 (the paper's ``g = [gx, gy, 0, 0]``).
    Environments written by users declare one of these to be usable by HI-DDPG.
    """

    indices: tuple[int, ...]
    low: tuple[float, ...]
    high: tuple[float, ...]

    def __post_init__(self) -> None:
        n = len(self.indices)
        if n == 0:
            raise ValueError("GoalSpace.indices must name at least one observation entry")
        if len(self.low) != n or len(self.high) != n:
            raise ValueError(
                f"GoalSpace: indices, low and high must have the same length, got "
                f"{n}, {len(self.low)}, {len(self.high)}"
            )
        for i, (lo, hi) in enumerate(zip(self.low, self.high, strict=True)):
            if not lo < hi:
                raise ValueError(f"GoalSpace: low[{i}]={lo} must be below high[{i}]={hi}")
        if len(set(self.indices)) != n or min(self.indices) < 0:
            raise ValueError(f"GoalSpace.indices must be distinct and >= 0, got {self.indices}")

    @property
    def dim(self) -> int:
        return len(self.indices)

    def embed(self, free: jax.Array, obs_dim: int) -> jax.Array:
        """Place the free goal entries (last axis ``dim``) into a zero vector of ``obs_dim``."""
        goal = jnp.zeros(free.shape[:-1] + (obs_dim,), free.dtype)
        return goal.at[..., jnp.asarray(self.indices)].set(free)

    def select(self, obs: jax.Array) -> jax.Array:
        """The goal entries ``P s`` of an observation (last axis)."""
        return obs[..., jnp.asarray(self.indices)]

    def scale(self, unit: jax.Array) -> jax.Array:
        """Map ``[-1, 1]`` (a tanh output) affinely onto ``[low, high]``."""
        return affine_unit(unit, jnp.asarray(self.low), jnp.asarray(self.high))

    def unscale(self, free: jax.Array) -> jax.Array:
        """Inverse of :meth:`scale`."""
        lo, hi = jnp.asarray(self.low), jnp.asarray(self.high)
        return 2.0 * (free - lo) / (hi - lo) - 1.0


class Environment:
    """Base class of the functional environments. Subclasses set the class attributes and
    implement :meth:`default_params`, :meth:`reset`, :meth:`step` and :meth:`dynamics`.

    Attributes:
        name: task name without namespace or version, e.g. ``"PuckTrajectory2"``.
        obs_dim: length of the observation vector.
        state_dim: length of the physical state ``state.x``.
        action_dim: length of the action vector.
        action_low, action_high: the normalised action box (scalars, same for every entry).
        dt: control period in seconds (time between two actions); the low-level model of
            HI-DDPG predicts ``s' = s + dt * f(s, a)``.
        goal_space: the :class:`GoalSpace` of this task.
    """

    name: str = "Environment"
    obs_dim: int
    state_dim: int
    action_dim: int
    action_low: float = -1.0
    action_high: float = 1.0
    dt: float
    goal_space: GoalSpace

    # -- to implement -------------------------------------------------------------------------
    def default_params(self, **overrides: Any) -> Any:
        """The spec's params with ``overrides`` applied, validated (errors name the field)."""
        raise NotImplementedError

    def reset(self, key: jax.Array, params: Any, options: Any = None) -> tuple[jax.Array, Any]:
        """Start an episode: returns ``(obs, state)``."""
        raise NotImplementedError

    def step(self, key: jax.Array, state: Any, action: jax.Array, params: Any) -> StepResult:
        """Apply one (normalised) action. ``info`` has a fixed structure of arrays."""
        raise NotImplementedError

    def dynamics(self, x: jax.Array, action: jax.Array, params: Any) -> jax.Array:
        """The differentiable physics of one control period on the physical state vector
        (no task logic, no termination): used by iLQR and by the Jacobian tests."""
        raise NotImplementedError

    # -- shared -------------------------------------------------------------------------------
    def max_steps(self, params: Any) -> int:
        """The horizon (a Python int, static under jit)."""
        return int(params.max_steps)

    def clip_action(self, action: jax.Array) -> jax.Array:
        """Clip to the normalised box (derivative 1 on the bound itself, see :func:`clip`)."""
        return clip(action, self.action_low, self.action_high)

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"

    def __hash__(self) -> int:
        return hash(type(self))

    def __eq__(self, other: object) -> bool:
        return type(self) is type(other)


def affine_unit(unit: jax.Array, low: Any, high: Any) -> jax.Array:
    """Map ``[-1, 1]`` onto ``[low, high]``, exact at both ends in floating point."""
    w = (unit + 1.0) * 0.5
    return low * (1.0 - w) + high * w


def clip(x: jax.Array, low: Any, high: Any) -> jax.Array:
    """``clip(x, low, high)`` whose derivative is 1 on the bounds themselves (``jnp.clip``
    gives ½ there, which stalls Newton-type solvers such as iLQR at active bounds)."""
    return jnp.where(x < low, low, jnp.where(x > high, high, x))


def check_choice(name: str, value: Any, allowed: tuple[Any, ...]) -> None:
    """Raise ``ValueError`` naming ``name`` unless ``value`` is one of ``allowed``."""
    if value not in allowed:
        raise ValueError(f"{name}={value!r} is not allowed; choose one of {list(allowed)}")


def check_range(
    name: str, value: Any, low: float | None = None, high: float | None = None,
    *, strict_low: bool = False,
) -> None:
    """Raise ``ValueError`` naming ``name`` if a finite scalar ``value`` is outside the range."""
    import math

    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name}={value!r} must be a number") from None
    if not math.isfinite(v):
        raise ValueError(f"{name}={value!r} must be finite")
    if low is not None and (v <= low if strict_low else v < low):
        op = ">" if strict_low else ">="
        raise ValueError(f"{name}={value!r} is out of range; it must be {op} {low}")
    if high is not None and v > high:
        raise ValueError(f"{name}={value!r} is out of range; it must be <= {high}")


def replace_params(params: Any, overrides: dict[str, Any]) -> Any:
    """``params.replace(**overrides)`` with an error naming unknown fields and the known ones."""
    known = {f.name for f in dataclasses.fields(params)}
    unknown = sorted(set(overrides) - known)
    if unknown:
        raise ValueError(
            f"unknown parameter(s) {unknown} for {type(params).__name__}; known: {sorted(known)}"
        )
    return params.replace(**overrides)

"""PuckWorld: a point mass with linear dynamics (spec ``environments.md`` §1 and §3).

State = observation ``s = [x, y, vx, vy]``; the normalised action ``a`` in ``[-1, 1]^2`` is the
force ``F = force_max * clip(a, -1, 1)``; one control period is the forward-Euler step
``s' = s + dt (A s + B F)``, ``A = [[0, I], [0, -damping I]]``, ``B = [[0], [I]]`` [paper form].

* :class:`PuckTrajectory1`/``2``/``3`` (§1.1): follow the reference trajectory that the
  discounted-LQR goal-reaching controller (:func:`reference_action`) draws through 1, 2 or 3
  reference goals; it is pre-computed into the params by ``default_params``.
* :class:`PuckObstacle` (§1.2): reach ``target`` without entering a disc.

Hierarchical agents' goals fix ``(x, y)`` within ``[-1, 3] x [-2.5, 2.5]`` (§3).

The params and state are defined in :mod:`hiddpg.envs.puck_params`, the dynamics and the
reference controller in :mod:`hiddpg.envs.puck_dynamics`; both are re-exported here.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from hiddpg.envs.base import Environment, StepResult, check_range, replace_params
from hiddpg.envs.puck_dynamics import (
    continuous_matrices,
    discrete_matrices,
    dynamics,
    lqr_gain,
    reference_action,
    reference_goal,
    reference_trajectory,
)
from hiddpg.envs.puck_params import (
    ACTION_DIM,
    DERIVED_FIELDS,
    GOAL_SPACE,
    POSITION,
    REFERENCE_GOALS,
    STATE_DIM,
    PuckObstacleParams,
    PuckParams,
    PuckState,
    PuckTrajectoryParams,
)

__all__ = [
    "ACTION_DIM", "DERIVED_FIELDS", "GOAL_SPACE", "POSITION", "REFERENCE_GOALS", "STATE_DIM",
    "PuckObstacle", "PuckObstacleParams", "PuckParams", "PuckState", "PuckTrajectory",
    "PuckTrajectory1", "PuckTrajectory2", "PuckTrajectory3", "PuckTrajectoryParams",
    "continuous_matrices", "discrete_matrices", "dynamics", "equal_split", "lqr_gain",
    "reference_action", "reference_goal", "reference_trajectory",
]

_reference_trajectory_jit = jax.jit(reference_trajectory)


def _distance(u: jax.Array, v: jax.Array) -> jax.Array:
    """``|u - v|_2`` with gradient 0 (not NaN) where ``u == v``."""
    sq = jnp.sum(jnp.square(u - v))
    positive = sq > 0
    return jnp.where(positive, jnp.sqrt(jnp.where(positive, sq, 1.0)), 0.0)


# -- validation -------------------------------------------------------------------------------
#: ``(field, low, high, strict_low)`` checks of the scalar physics and LQR fields.
_SCALAR_RANGES = (
    ("dt", 0.0, None, True), ("damping", 0.0, None, False), ("force_max", 0.0, None, True),
    ("lqr_position_weight", 0.0, None, True), ("lqr_action_weight", 0.0, None, True),
    ("lqr_discount", 0.0, 1.0, True),
)


def _vector(name: str, value: Any, shape: tuple[int | None, ...]) -> np.ndarray:
    """``value`` as a finite float64 array of ``shape`` (``None``: any length >= 1)."""
    try:
        array = np.asarray(value, np.float64)
    except (TypeError, ValueError):
        array = np.full((), np.nan)
    ok = array.ndim == len(shape) and all(
        n == want if want is not None else n >= 1
        for n, want in zip(array.shape, shape, strict=True)
    )
    if not ok or not np.all(np.isfinite(array)):
        wanted = tuple("n" if n is None else n for n in shape)
        raise ValueError(f"{name} must be a finite array of shape {wanted}, got {value!r}")
    return array


def _apply_overrides(params: PuckParams, overrides: dict[str, Any]) -> PuckParams:
    """Apply and validate the overrides of the shared fields, then compute ``lqr_gain``."""
    derived = sorted(set(overrides) & set(DERIVED_FIELDS))
    if derived:
        raise ValueError(f"{derived} are derived by default_params and cannot be overridden")
    params = replace_params(params, overrides)
    for name, low, high, strict in _SCALAR_RANGES:
        check_range(name, getattr(params, name), low, high, strict_low=strict)
    if isinstance(params.max_steps, bool) or not isinstance(params.max_steps, int | np.integer):
        raise ValueError(f"max_steps={params.max_steps!r} must be a Python int >= 1")
    check_range("max_steps", params.max_steps, 1)
    init_state = _vector("init_state", params.init_state, (STATE_DIM,))
    params = params.replace(
        max_steps=int(params.max_steps), init_state=jnp.asarray(init_state, jnp.float32)
    )
    return params.replace(lqr_gain=lqr_gain(params))


def equal_split(n_goals: int, horizon: int) -> tuple[int, ...]:
    """Switch steps dividing ``horizon`` actions equally among ``n_goals`` goals (§1.1)."""
    return tuple(i * horizon // n_goals for i in range(1, n_goals))


def _schedule(params: PuckTrajectoryParams) -> PuckTrajectoryParams:
    """Validate ``goals`` and ``switch_steps`` (``None``: :func:`equal_split`)."""
    goals = _vector("goals", params.goals, (None, len(GOAL_SPACE.indices)))
    n, horizon = len(goals), params.max_steps
    switch = params.switch_steps
    switch = np.asarray(equal_split(n, horizon) if switch is None else switch)
    if switch.shape != (n - 1,) or (switch.size and (
            not np.all(switch == np.round(switch)) or np.any(np.diff(switch) <= 0)
            or switch.min() < 1 or switch.max() > horizon - 1)):
        raise ValueError(
            f"switch_steps={switch.tolist()} is not allowed with {n} goals and max_steps="
            f"{horizon}; it must be {n - 1} strictly increasing ints in [1, max_steps - 1]"
        )
    return params.replace(
        goals=jnp.asarray(goals, jnp.float32), switch_steps=jnp.asarray(switch, jnp.int32)
    )


# -- tasks ------------------------------------------------------------------------------------
class _Puck(Environment):
    obs_dim = STATE_DIM
    state_dim = STATE_DIM
    action_dim = ACTION_DIM
    dt = {f.name: f.default for f in dataclasses.fields(PuckParams)}["dt"]
    goal_space = GOAL_SPACE

    def reset(
        self, key: jax.Array, params: PuckParams, options: Any = None,
    ) -> tuple[jax.Array, PuckState]:
        """Deterministic start at ``params.init_state`` (``key`` is unused; ``options`` may hold
        ``{"init_state": (4,)}`` to start elsewhere)."""
        options = dict(options or {})
        x = jnp.asarray(options.pop("init_state", params.init_state), jnp.float32)
        if options:
            raise ValueError(f"unknown reset options {sorted(options)}; known: ['init_state']")
        state = PuckState(x=x, t=jnp.zeros((), jnp.int32))
        return state.x, state

    def dynamics(self, x: jax.Array, action: jax.Array, params: PuckParams) -> jax.Array:
        return dynamics(x, action, params)

    def reference_controller(self, obs: jax.Array, goal: jax.Array,
                             params: PuckParams) -> jax.Array:
        """:func:`reference_action` towards a full goal vector (HI-DDPG's
        :class:`hiddpg.experiments.overrides.ReferenceLowLevel`)."""
        return reference_action(obs, self.goal_space.select(goal), params)


class PuckTrajectory(_Puck):
    """Trajectory following (§1.1) through the ``n_goals`` reference goals of the spec.

    ``info``: ``p_ref`` ``(2,)`` reference position after this step, ``goal`` ``(2,)`` the
    reference goal this step aimed at, ``goals`` ``(n_goals, 2)`` all reference goals.
    """

    name, n_goals = "PuckTrajectory", 1

    def default_params(self, **overrides: Any) -> PuckTrajectoryParams:
        """Spec defaults, then ``overrides``; then ``lqr_gain`` and the reference trajectory
        are computed from the final values (so ``default_params(dt=0.05)`` is consistent)."""
        params = PuckTrajectoryParams(goals=jnp.asarray(REFERENCE_GOALS[self.n_goals]))
        params = _schedule(_apply_overrides(params, overrides))
        check_range("tracking_weight", params.tracking_weight, 0.0, strict_low=True)
        states, actions = _reference_trajectory_jit(params.goals, params.switch_steps, params)
        return params.replace(ref_states=states, ref_actions=actions)

    def step(
        self, key: jax.Array, state: PuckState, action: jax.Array, params: PuckTrajectoryParams,
    ) -> StepResult:
        """Reward ``-w |p_k - p_ref_k|`` after ``k`` actions (``w = tracking_weight``);
        terminated once ``k >= max_steps`` (steps past the horizon compare with the last
        reference state)."""
        x = dynamics(state.x, action, params)
        t = state.t + 1
        index = jnp.minimum(t, params.max_steps) - 1
        p_ref = params.ref_states[index, POSITION]
        reward = -params.tracking_weight * _distance(x[POSITION], p_ref)
        goal = reference_goal(index, params.goals, params.switch_steps)
        info = {"p_ref": p_ref, "goal": goal, "goals": params.goals}
        return StepResult(
            obs=x, state=PuckState(x=x, t=t), reward=reward, terminated=t >= params.max_steps,
            truncated=jnp.zeros((), bool), info=info,
        )


class PuckTrajectory1(PuckTrajectory):
    """One reference goal ``[1.5, 0.35]``."""

    name, n_goals = "PuckTrajectory1", 1


class PuckTrajectory2(PuckTrajectory):
    """Two reference goals, switch at step 15."""

    name, n_goals = "PuckTrajectory2", 2


class PuckTrajectory3(PuckTrajectory):
    """Three reference goals, switches at steps 10 and 20 ("virtual goals")."""

    name, n_goals = "PuckTrajectory3", 3


class PuckObstacle(_Puck):
    """Obstacle avoidance (§1.2): reward ``-|p - target|``; entering the disc gives
    ``collision_penalty`` and terminates; truncated after ``max_steps`` actions.

    ``info``: ``collision`` (bool), ``target_distance`` and ``obstacle_distance`` (distances of
    the puck centre to the target and to the obstacle centre after this step).
    """

    name = "PuckObstacle"

    def default_params(self, **overrides: Any) -> PuckObstacleParams:
        """Spec defaults, then ``overrides``, validated; ``lqr_gain`` computed last."""
        params = _apply_overrides(PuckObstacleParams(), overrides)
        target = _vector("target", params.target, (2,))
        center = _vector("obstacle_center", params.obstacle_center, (2,))
        check_range("obstacle_radius", params.obstacle_radius, 0.0, strict_low=True)
        check_range("collision_penalty", params.collision_penalty)
        start = np.asarray(params.init_state[POSITION], np.float64)
        for name, point in (("init_state", start), ("target", target)):
            if np.linalg.norm(point - center) < params.obstacle_radius:
                raise ValueError(f"{name} lies inside the obstacle (obstacle_center, radius)")
        return params.replace(
            target=jnp.asarray(target, jnp.float32),
            obstacle_center=jnp.asarray(center, jnp.float32),
        )

    def step(
        self, key: jax.Array, state: PuckState, action: jax.Array, params: PuckObstacleParams,
    ) -> StepResult:
        """Reward ``-|p - target|``, or ``collision_penalty`` and terminated on a collision."""
        x = dynamics(state.x, action, params)
        t = state.t + 1
        target_distance = _distance(x[POSITION], params.target)
        obstacle_distance = _distance(x[POSITION], params.obstacle_center)
        collision = obstacle_distance < params.obstacle_radius
        reward = jnp.where(collision, params.collision_penalty, -target_distance)
        info = {"collision": collision, "target_distance": target_distance,
                "obstacle_distance": obstacle_distance}
        return StepResult(
            obs=x, state=PuckState(x=x, t=t), reward=reward.astype(jnp.float32),
            terminated=collision, truncated=(t >= params.max_steps) & ~collision, info=info,
        )

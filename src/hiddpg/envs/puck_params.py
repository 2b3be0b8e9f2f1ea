"""PuckWorld's constants, params and state (spec ``environments.md`` §1 and §3)."""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
from flax import struct

from hiddpg.envs.base import GoalSpace

STATE_DIM = 4
ACTION_DIM = 2
#: The position entries of the state (those a goal fixes).
POSITION = slice(0, 2)
#: §3: goals fix ``x, y`` within the bounds below ([paper] form, [decision] bounds).
GOAL_SPACE = GoalSpace(indices=(0, 1), low=(-1.0, -2.5), high=(3.0, 2.5))
#: §1.1 reference goals of the three trajectory tasks ([paper]).
REFERENCE_GOALS: dict[int, tuple[tuple[float, float], ...]] = {
    1: ((1.5, 0.35),),
    2: ((1.2, -0.9), (2.3, 1.5)),
    3: ((1.5, -1.5), (1.5, 1.5), (2.0, -1.8)),
}
#: Fields computed by ``default_params``; overriding them is an error.
DERIVED_FIELDS = ("lqr_gain", "ref_states", "ref_actions")


def _array(*values: Any) -> Any:
    """A float32 default factory for a dataclass field."""
    return struct.field(default_factory=lambda: jnp.asarray(values, jnp.float32))


@struct.dataclass
class PuckParams:
    """Physics shared by every PuckWorld task (§1) and the LQR goal-reaching controller.

    Attributes:
        dt: control period in seconds [decision]; ``v' = (1 - damping dt) v + dt F``.
        damping: linear velocity damping per second, unit mass [decision].
        force_max: force bound; the normalised action ``[-1, 1]`` is scaled by it [decision].
        init_state: ``(4,)`` state at reset ([paper] for the trajectory tasks).
        max_steps: horizon in actions (static Python int).
        lqr_position_weight: weight of ``|p - g|^2`` in the LQR stage cost [decision].
        lqr_action_weight: weight of ``|F|^2`` in the LQR stage cost [decision].
        lqr_discount: discount of the LQR cost, that of HI-DDPG's low level [decision].
        lqr_gain: ``(2, 4)`` derived: the discounted LQR gain ``K`` (force units) of the
            discretised system, filled in by ``default_params``.
    """

    dt: float = 0.1
    damping: float = 0.5
    force_max: float = 10.0
    init_state: jax.Array = _array(0.0, 0.0, 0.5, 0.5)
    max_steps: int = struct.field(pytree_node=False, default=30)
    lqr_position_weight: float = 1.0
    lqr_action_weight: float = 0.03
    lqr_discount: float = 0.95
    lqr_gain: jax.Array | None = None


@struct.dataclass
class PuckTrajectoryParams(PuckParams):
    """Params of the trajectory-following tasks (§1.1).

    Attributes:
        goals: ``(n_goals, 2)`` reference goals ([paper]).
        switch_steps: ``(n_goals - 1,)`` int32: action ``k`` (0-based) aims at goal
            ``#{s in switch_steps : s <= k}``; ``None`` in ``default_params`` means the equal
            split of the horizon (none; 15; 10 and 20 for 30 steps) [decision].
        tracking_weight: ``w`` of the reward ``-w |p - p_ref|`` [decision]: 2, so that at the
            paper's switch cost the reference plan is the best plan of every trajectory task
            (docs/environments.md).
        ref_states: ``(max_steps, 4)`` derived: reference state after each action.
        ref_actions: ``(max_steps, 2)`` derived: normalised actions producing ``ref_states``.
    """

    goals: jax.Array = struct.field(
        default_factory=lambda: jnp.asarray(REFERENCE_GOALS[1], jnp.float32)
    )
    switch_steps: jax.Array | None = None
    tracking_weight: float = 2.0
    ref_states: jax.Array | None = None
    ref_actions: jax.Array | None = None


@struct.dataclass
class PuckObstacleParams(PuckParams):
    """Params of the obstacle task (§1.2, all [decision]).

    Attributes:
        target: ``(2,)`` position to reach.
        obstacle_center: ``(2,)`` centre of the disc.
        obstacle_radius: collision when the puck centre is closer than this to the centre.
        collision_penalty: reward of the colliding step (which terminates the episode).
    """

    init_state: jax.Array = _array(0.0, 0.0, 0.0, 0.0)
    max_steps: int = struct.field(pytree_node=False, default=50)
    target: jax.Array = _array(2.0, 0.0)
    obstacle_center: jax.Array = _array(1.0, 0.0)
    obstacle_radius: float = 0.3
    collision_penalty: float = -150.0


@struct.dataclass
class PuckState:
    """``x``: ``(4,)`` ``[x, y, vx, vy]``; ``t``: int32 number of actions taken."""

    x: jax.Array
    t: jax.Array

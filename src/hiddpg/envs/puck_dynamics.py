"""PuckWorld's linear dynamics and its discounted-LQR goal-reaching reference controller (§1.1)."""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from hiddpg.envs.base import clip
from hiddpg.envs.lqr import discounted_lqr
from hiddpg.envs.puck_params import ACTION_DIM, GOAL_SPACE, STATE_DIM, PuckParams


def continuous_matrices(damping: Any, dtype: Any = jnp.float32) -> tuple[jax.Array, jax.Array]:
    """The spec's ``(A, B)`` of ``ds/dt = A s + B F`` (unit mass, linear damping)."""
    eye = jnp.eye(ACTION_DIM, dtype=dtype)
    zero = jnp.zeros((ACTION_DIM, ACTION_DIM), dtype)
    A = jnp.block([[zero, eye], [zero, -damping * eye]])
    B = jnp.concatenate([zero, eye])
    return A, B


def discrete_matrices(params: PuckParams) -> tuple[jax.Array, jax.Array]:
    """Forward-Euler ``(A_d, B_d) = (I + dt A, dt B)`` in force units: ``s' = A_d s + B_d F``."""
    A, B = continuous_matrices(params.damping)
    return jnp.eye(STATE_DIM) + params.dt * A, params.dt * B


def dynamics(x: jax.Array, action: jax.Array, params: PuckParams) -> jax.Array:
    """One control period ``s' = s + dt (A s + B F)``, ``F = force_max * clip(action, -1, 1)``
    (the result keeps the dtype of ``x``)."""
    A, B = continuous_matrices(params.damping, x.dtype)
    force = params.force_max * clip(action, -1.0, 1.0)
    return (x + params.dt * (A @ x + B @ force)).astype(x.dtype)


def lqr_gain(params: PuckParams) -> jax.Array:
    """The discounted LQR gain ``K`` (§1.1) for stage cost
    ``w_p |p - g|^2 + w_a |F|^2`` on the discretised system (float32, ``(2, 4)``)."""
    A_d, B_d = (np.asarray(m, np.float64) for m in discrete_matrices(params))
    select = np.eye(STATE_DIM)[list(GOAL_SPACE.indices)]
    Q = float(params.lqr_position_weight) * select.T @ select
    R = float(params.lqr_action_weight) * np.eye(ACTION_DIM)
    K, _ = discounted_lqr(A_d, B_d, Q, R, float(params.lqr_discount))
    return jnp.asarray(K, jnp.float32)


def reference_action(obs: jax.Array, goal_xy: jax.Array, params: PuckParams) -> jax.Array:
    """The LQR goal-reaching controller as a normalised action:
    ``clip(-K (s - [gx, gy, 0, 0]), -force_max, force_max) / force_max``."""
    goal = GOAL_SPACE.embed(jnp.asarray(goal_xy, jnp.float32), STATE_DIM)
    force = jnp.clip(-params.lqr_gain @ (obs - goal), -params.force_max, params.force_max)
    return force / params.force_max


def reference_goal(k: jax.Array, goals: jax.Array, switch_steps: jax.Array) -> jax.Array:
    """The goal that action ``k`` (0-based) aims at: goal ``#{s in switch_steps : s <= k}``."""
    return goals[jnp.sum(k >= switch_steps)]


def reference_trajectory(
    goals: jax.Array, switch_steps: jax.Array, params: PuckParams,
) -> tuple[jax.Array, jax.Array]:
    """Run :func:`reference_action` from ``init_state`` for ``max_steps`` actions through
    ``goals`` (switching at ``switch_steps``): ``(max_steps, 4)`` states after each action and
    the ``(max_steps, 2)`` normalised actions."""
    goals, switch_steps = jnp.asarray(goals, jnp.float32), jnp.asarray(switch_steps, jnp.int32)

    def control(x, k):
        action = reference_action(x, reference_goal(k, goals, switch_steps), params)
        x_next = dynamics(x, action, params)
        return x_next, (x_next, action)

    steps = jnp.arange(params.max_steps, dtype=jnp.int32)
    _, (states, actions) = jax.lax.scan(control, params.init_state, steps)
    return states, actions

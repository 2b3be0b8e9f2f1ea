"""Cost builders for :func:`hiddpg.control.ilqr.ilqr`, and :func:`solve_task` for any hiddpg env.

Conventions (those of PuckWorld's reference, spec ``environments.md`` §1.1): the horizon is
``T`` actions; ``x_k`` is the state after ``k`` actions; action ``k`` (0-based) aims at goal
``#{s in switch_times : s <= k}``. A goal fixes the entries ``P x`` named by the env's
:class:`~hiddpg.envs.base.GoalSpace` (``indices`` address the state vector ``x``; in every hiddpg
env they are the leading entries, shared by state and observation).

* :func:`goal_tracking_cost` — the cost of spec ``algorithms.md`` §5,
  ``Σ_{k=1..T} w |P x_k - g_k|² + Σ_{k<T} r |u_k|²`` where ``g_k`` is the goal of the action that
  produced ``x_k`` (as the low level of HI-DDPG is rewarded for ``s_{t+1}`` against ``g_t``).
  Optionally the last state gets its own weight.
* :func:`target_reaching_cost` — a single target state with separate running and final
  (diagonal) weights: ``Σ_{k<T} (|x_k - x*|²_W + r |u_k|²) + |x_T - x*|²_{W_f}``.

Costs are not halved (no ``½``), matching the spec's ``|p - g|² + 0.03 |a|²``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp

from hiddpg.control.ilqr import ILQRConfig, ILQRResult, ilqr


class Cost(NamedTuple):
    """A cost for :func:`~hiddpg.control.ilqr.ilqr`: ``running(x, u, t)`` and ``final(x)``."""

    running: Callable[[jax.Array, jax.Array, jax.Array], jax.Array]
    final: Callable[[jax.Array], jax.Array]

    def total(self, states: jax.Array, actions: jax.Array) -> jax.Array:
        """``Σ_t running(x_t, u_t, t) + final(x_T)`` of a ``(T + 1, n)``, ``(T, m)`` trajectory."""
        times = jnp.arange(actions.shape[0], dtype=jnp.int32)
        return jnp.sum(jax.vmap(self.running)(states[:-1], actions, times)) + self.final(
            states[-1]
        )


def goal_schedule(goals: jax.Array, switch_times: Any, horizon: int) -> jax.Array:
    """The goal of every action: ``(T, d)``, row ``k`` = ``goals[#{s in switch_times : s <= k}]``.

    Args:
        goals: ``(K, d)`` goals (the free entries), or ``(d,)`` for one goal.
        switch_times: ``K - 1`` increasing action indices where the next goal starts.
        horizon: ``T`` (a Python int).
    """
    goals = jnp.atleast_2d(jnp.asarray(goals))
    switch = jnp.asarray(switch_times, jnp.int32).reshape(-1)
    if switch.shape[0] != goals.shape[0] - 1:
        raise ValueError(
            f"switch_times has {switch.shape[0]} entries; {goals.shape[0]} goals need "
            f"{goals.shape[0] - 1}"
        )
    steps = jnp.arange(horizon, dtype=jnp.int32)
    return goals[jnp.sum(steps[:, None] >= switch[None, :], axis=1)]


def goal_tracking_cost(
    goals: jax.Array, switch_times: Any, horizon: int, indices: Sequence[int], *,
    weight: float = 1.0, action_weight: float = 0.01, final_weight: float | None = None,
) -> Cost:
    """``Σ_{k=1..T} w_k |P x_k - g_k|² + r Σ_k |u_k|²`` with the goal schedule of
    :func:`goal_schedule`; ``w_k = weight`` except ``w_T = final_weight`` (default ``weight``).

    The running cost at time ``t`` charges ``x_t`` against the goal of action ``t - 1`` (nothing
    at ``t = 0``: ``x_0`` is given) and ``u_t``; the final cost charges ``x_T``.
    """
    schedule = goal_schedule(goals, switch_times, horizon)
    idx = jnp.asarray(tuple(indices), jnp.int32)
    w_final = weight if final_weight is None else final_weight

    def running(x, u, t):
        error = x[idx] - schedule[jnp.maximum(t - 1, 0)]
        charged = jnp.where(t > 0, weight, 0.0)
        return charged * jnp.sum(jnp.square(error)) + action_weight * jnp.sum(jnp.square(u))

    def final(x):
        return w_final * jnp.sum(jnp.square(x[idx] - schedule[-1]))

    return Cost(running, final)


def target_reaching_cost(
    target: jax.Array, *, running_weight: Any = 0.0, final_weight: Any = 1.0,
    action_weight: float = 0.01,
) -> Cost:
    """``Σ_{t<T} (|x_t - x*|²_W + r |u_t|²) + |x_T - x*|²_{W_f}`` with diagonal weights.

    Args:
        target: ``(n,)`` target state ``x*``.
        running_weight: ``W``, a scalar or ``(n,)`` (0 entries leave a state entry free).
        final_weight: ``W_f``, a scalar or ``(n,)``.
        action_weight: ``r``.
    """
    target = jnp.asarray(target)
    w_run = jnp.broadcast_to(jnp.asarray(running_weight, target.dtype), target.shape)
    w_fin = jnp.broadcast_to(jnp.asarray(final_weight, target.dtype), target.shape)

    def running(x, u, t):
        del t
        return jnp.sum(w_run * jnp.square(x - target)) + action_weight * jnp.sum(jnp.square(u))

    def final(x):
        return jnp.sum(w_fin * jnp.square(x - target))

    return Cost(running, final)


def solve_task(
    env: Any, params: Any, x0: jax.Array, horizon: int, goals: jax.Array,
    switch_times: Any = (), *, weight: float = 1.0, action_weight: float = 0.01,
    final_weight: float | None = None, u_init: jax.Array | None = None, bounded: bool = True,
    config: ILQRConfig | None = None,
) -> ILQRResult:
    """iLQR on a hiddpg environment: track ``goals`` (switching at ``switch_times``) with
    :func:`goal_tracking_cost` on the env's goal entries, using ``env.dynamics`` as the model.

    Args:
        env: a :class:`~hiddpg.envs.base.Environment` (uses ``dynamics``, ``goal_space``,
            ``action_dim``, ``action_low``, ``action_high``).
        params: the env's params.
        x0: ``(state_dim,)`` start state.
        horizon: ``T``, the number of actions (a Python int).
        goals: ``(K, goal_space.dim)`` goals, or ``(goal_space.dim,)`` for one.
        switch_times: ``K - 1`` action indices where the next goal starts.
        weight, action_weight, final_weight: see :func:`goal_tracking_cost`; actions are in the
            env's normalised box.
        u_init: ``(T, action_dim)`` initial actions; default the middle of the action box.
        bounded: respect the env's action box (box-QP); ``False`` leaves actions free (the env
            still clips internally, so use it only where the bounds stay inactive).
        config: solver settings (default :class:`~hiddpg.control.ilqr.ILQRConfig`).
    """
    x0 = jnp.asarray(x0)
    goals = jnp.atleast_2d(jnp.asarray(goals, x0.dtype))
    if goals.shape[-1] != env.goal_space.dim:
        raise ValueError(
            f"goals have {goals.shape[-1]} entries; {env.name}'s goal space has "
            f"{env.goal_space.dim} (indices {env.goal_space.indices})"
        )
    cost = goal_tracking_cost(
        goals, switch_times, horizon, env.goal_space.indices, weight=weight,
        action_weight=action_weight, final_weight=final_weight,
    )
    if u_init is None:
        middle = 0.5 * (env.action_low + env.action_high)
        u_init = jnp.full((horizon, env.action_dim), middle, x0.dtype)
    box = (env.action_low, env.action_high) if bounded else (None, None)
    return ilqr(
        lambda x, u: env.dynamics(x, u, params), cost.running, cost.final, x0, u_init,
        action_low=box[0], action_high=box[1], config=config or ILQRConfig(),
    )

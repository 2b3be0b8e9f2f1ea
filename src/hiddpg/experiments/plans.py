"""The best plans of the puck trajectory tasks, driven by the reference controller.

A *plan* is a goal sequence with its switch steps. Driven by the puck's reference (LQR)
controller — the one that drew the task's reference trajectory (spec §1.1) — a plan's
high-level return is ``-w Σ_k |p_k - p_ref,k| - c_switch (n - 1)`` (``w`` the task's
``tracking_weight``), the return HI-DDPG's high level maximises. For each goal count ``n``
:func:`best_plans` finds the best plan: every set of ``n - 1`` switch steps, each with its
goals fitted by Adam on the differentiable rollout (from the mean reference goal, step size
cosine-decayed, clipped to the goal bounds), the best set kept.

It answers whether the reference plan — the one the paper's claims 1-2 expect the high level
to find — is the optimum of the task's return, the question that sets ``tracking_weight``
(the answers per task and weight: docs/environments.md).
"""

from __future__ import annotations

import itertools
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
import optax

from hiddpg.envs.puckworld import GOAL_SPACE, POSITION, reference_trajectory


def tracking_return(params: Any, goals: jax.Array, switch_steps: jax.Array) -> jax.Array:
    """``-w Σ_k |p_k - p_ref,k|`` of the reference controller through ``goals`` switching at
    ``switch_steps`` (a PuckTrajectory task's reward summed, ``w = tracking_weight``; the norm
    is smoothed by 1e-12 under the root so that its gradient exists at 0)."""
    states, _ = reference_trajectory(goals, switch_steps, params)
    error = states[:, POSITION] - params.ref_states[:, POSITION]
    distance = jnp.sqrt(jnp.sum(jnp.square(error), axis=-1) + 1e-12)
    return -params.tracking_weight * jnp.sum(distance)


def _fit(params: Any, n_goals: int, steps: int, lr: float):
    low, high = jnp.asarray(GOAL_SPACE.low), jnp.asarray(GOAL_SPACE.high)
    opt = optax.adam(optax.cosine_decay_schedule(lr, steps))
    start = jnp.tile(jnp.mean(params.goals, axis=0), (n_goals, 1))

    def fit(switch_steps: jax.Array):
        def body(carry, _):
            goals, opt_state = carry
            grad = jax.grad(lambda g: -tracking_return(params, g, switch_steps))(goals)
            updates, opt_state = opt.update(grad, opt_state)
            goals = jnp.clip(optax.apply_updates(goals, updates), low, high)
            return (goals, opt_state), None

        (goals, _), _ = jax.lax.scan(body, (start, opt.init(start)), None, length=steps)
        return goals, tracking_return(params, goals, switch_steps)

    return jax.jit(jax.vmap(fit))


def best_plans(params: Any, max_goals: int = 3, switch_cost: float = 10.0, steps: int = 600,
               lr: float = 0.05) -> list[dict[str, Any]]:
    """For ``n = 1 .. max_goals`` goals: the best plan found (``switch_steps``, ``goals``,
    ``tracking`` return, ``return`` = tracking − ``switch_cost`` (n − 1)), and first the
    reference plan itself (``n_goals`` = its count, ``reference`` = True)."""
    if max_goals < 1:
        raise ValueError(f"max_goals={max_goals} must be >= 1")
    horizon = int(params.max_steps)
    ref_goals, ref_switch = jnp.asarray(params.goals), jnp.asarray(params.switch_steps)
    ref_tracking = float(tracking_return(params, ref_goals, ref_switch))
    out = [{"n_goals": len(ref_goals), "reference": True,
            "switch_steps": np.asarray(ref_switch).tolist(),
            "goals": np.asarray(ref_goals).tolist(), "tracking": ref_tracking,
            "return": ref_tracking - switch_cost * (len(ref_goals) - 1)}]
    for n in range(1, max_goals + 1):
        combos = list(itertools.combinations(range(1, horizon), n - 1))
        schedules = jnp.asarray(np.array(combos, np.int32).reshape(len(combos), n - 1))
        goals, tracking = _fit(params, n, steps, lr)(schedules)
        i = int(jnp.argmax(tracking))
        out.append({"n_goals": n, "reference": False,
                    "switch_steps": np.asarray(schedules[i]).tolist(),
                    "goals": np.asarray(goals[i]).tolist(), "tracking": float(tracking[i]),
                    "return": float(tracking[i]) - switch_cost * (n - 1)})
    return out

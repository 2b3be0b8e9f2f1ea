"""Observation boxes of the built-in tasks, for the Gymnasium adapter (:mod:`hiddpg.envs.gym`).

Each is ``(env, params) -> (low, high)``, declared by the task's ``obs_bounds`` in
:data:`hiddpg.envs.TASKS`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from hiddpg.envs.base import Environment

#: Bound of observation entries no rule covers (finite, so ``check_env`` does not warn).
UNBOUNDED = 1.0e4
#: Bound on the arm's joint speeds in the observation box, rad/s, times ``max(1, force_scale)``
#: [decision; docs/environments.md]: well above the fastest joint movement the muscles produce.
ARM_MAX_SPEED = 50.0


def puck_bounds(core: Environment, params: Any) -> tuple[np.ndarray, np.ndarray]:
    """A box no episode can leave: per axis, ``|F| <= force_max`` gives the recursion
    ``v' <= |1 - damping dt| v + dt force_max``, ``p' <= p + dt v`` over ``max_steps``."""
    del core
    x0 = np.abs(np.asarray(params.init_state, np.float64))
    p, v = x0[:2].max(), x0[2:].max()
    dt, decay = float(params.dt), abs(1.0 - float(params.damping) * float(params.dt))
    vmax = v
    for _ in range(params.max_steps):
        p, v = p + dt * v, decay * v + dt * float(params.force_max)
        vmax = max(vmax, v)
    high = np.array([p, p, vmax, vmax]) * 1.5 + 1.0  # margin for float32 rounding
    return -high, high


def arm_bounds(core: Environment, params: Any) -> tuple[np.ndarray, np.ndarray]:
    """Joint limits for angles (and for ArmReach's target angles), ``ARM_MAX_SPEED`` for speeds."""
    speed = ARM_MAX_SPEED * max(1.0, float(params.force_scale))
    lo, hi = np.asarray(params.joint_low, np.float64), np.asarray(params.joint_high, np.float64)
    low = np.concatenate([lo, [-speed, -speed]])
    high = np.concatenate([hi, [speed, speed]])
    extra = core.obs_dim - len(low)  # ArmReach appends the target angles
    if extra == 2:
        low, high = np.concatenate([low, lo]), np.concatenate([high, hi])
    elif extra:
        low = np.concatenate([low, np.full(extra, -UNBOUNDED)])
        high = np.concatenate([high, np.full(extra, UNBOUNDED)])
    return low, high


def unbounded(core: Environment, params: Any) -> tuple[np.ndarray, np.ndarray]:
    """``±UNBOUNDED`` for every entry."""
    del params
    high = np.full(core.obs_dim, UNBOUNDED)
    return -high, high

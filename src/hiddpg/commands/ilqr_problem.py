"""The iLQR problem of an ``hiddpg ilqr`` command line: the task, goals, switch times, horizon
and action weight, parsed, defaulted and validated (:func:`resolve`).

[decision] marks a value of ours where the paper is silent; docs/deviations.md (each with the
paper's value and why) lists them."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from hiddpg.commands.common import UsageError
from hiddpg.envs import make, task_name

#: Default action weight ``r`` where the task has no reference controller [decision]:
#: normalised puck forces, and muscle activations (as in ``benchmarks/ilqr.py``).
PUCK_ACTION_WEIGHT = 0.01
ARM_ACTION_WEIGHT = 1e-3


@dataclass(frozen=True)
class Problem:
    """A resolved iLQR problem on a task.

    Attributes:
        task: the task name.
        env, params: the task's core and params (after ``--set``).
        state: the reset state (``state.x`` is the start state).
        horizon: ``T``, the number of actions.
        goals: ``(K, goal_dim)`` goals in the task's goal space.
        switch_times: ``K - 1`` increasing action indices in ``[1, T - 1]``.
        action_weight: ``r``.
        target: ArmReach's drawn joint target (drawn in the GIF), else ``None``.
    """

    task: str
    env: Any
    params: Any
    state: Any
    horizon: int
    goals: np.ndarray
    switch_times: tuple[int, ...]
    action_weight: float
    target: np.ndarray | None = None

    def cost(self):
        """The :class:`~hiddpg.control.Cost` that :func:`hiddpg.commands.ilqr_solution.solve`
        minimises."""
        from hiddpg.control import goal_tracking_cost

        return goal_tracking_cost(
            jnp.asarray(self.goals, jnp.float32), self.switch_times, self.horizon,
            self.env.goal_space.indices, action_weight=self.action_weight,
        )

    def step_goals(self) -> np.ndarray:
        """``(T, goal_dim)``: the goal of every action."""
        from hiddpg.control import goal_schedule

        return np.asarray(goal_schedule(jnp.asarray(self.goals, jnp.float32),
                                        self.switch_times, self.horizon))


# -- parsing and validation -------------------------------------------------------------------
def parse_goals(text: str, dim: int, task: str) -> np.ndarray:
    """``"x,y;x,y"`` -> ``(K, dim)``; errors name ``--goals`` and the value."""
    rows = [row.strip() for row in text.split(";")]
    if not text.strip() or any(not row for row in rows):
        raise UsageError(f"--goals {text!r} has an empty goal; write goals as 'x,y;x,y' "
                         f"({dim} numbers per goal, goals separated by ';')")
    goals = []
    for i, row in enumerate(rows, 1):
        entries = [e.strip() for e in row.split(",")]
        try:
            values = [float(e) for e in entries]
        except ValueError:
            raise UsageError(f"--goals {text!r}: goal {i} {row!r} is not {dim} numbers "
                             f"separated by ','") from None
        if len(values) != dim:
            raise UsageError(f"--goals {text!r}: goal {i} has {len(values)} entries; {task}'s "
                             f"goals have {dim} (one per goal-space entry)")
        if not all(math.isfinite(v) for v in values):
            raise UsageError(f"--goals {text!r}: goal {i} is not finite")
        goals.append(values)
    return np.asarray(goals, np.float64)


def parse_switch_times(text: str) -> tuple[int, ...]:
    """``"10,20"`` -> ``(10, 20)``; ``""`` -> ``()``."""
    if not text.strip():
        return ()
    times = []
    for part in text.split(","):
        try:
            times.append(int(part.strip()))
        except ValueError:
            raise UsageError(f"--switch-times {text!r}: {part.strip()!r} is not an integer "
                             "action index; write them as '10,20'") from None
    return tuple(times)


def check_goals(goals: np.ndarray, env: Any, label: str) -> None:
    """Every goal inside the task's goal space (where HI-DDPG's high level can put one)."""
    space = env.goal_space
    low, high = np.asarray(space.low), np.asarray(space.high)
    for i, g in enumerate(goals, 1):
        if np.any(g < low) or np.any(g > high):
            box = " x ".join(f"[{lo:g}, {hi:g}]" for lo, hi in zip(low, high, strict=True))
            raise UsageError(f"{label}: goal {i} {tuple(round(float(v), 6) for v in g)} is "
                             f"outside {env.name}'s goal space {box}")


def check_switch_times(times: tuple[int, ...], n_goals: int, horizon: int, label: str) -> None:
    """``n_goals - 1`` strictly increasing action indices in ``[1, horizon - 1]``."""
    k = n_goals - 1
    allowed = ("empty (one goal)" if k == 0 else
               f"{k} strictly increasing action {'index' if k == 1 else 'indices'} in "
               f"[1, {horizon - 1}] (horizon {horizon})")
    if len(times) != n_goals - 1:
        raise UsageError(f"{label}: {len(times)} switch time(s) for {n_goals} goal(s); "
                         f"it must be {allowed}")
    outside = [t for t in times if not 1 <= t <= horizon - 1]
    if outside:
        raise UsageError(f"{label}: {outside} outside the horizon; it must be {allowed}")
    if any(b <= a for a, b in zip(times, times[1:], strict=False)):
        raise UsageError(f"{label}: not strictly increasing; it must be {allowed}")


def _task_defaults(env: Any, params: Any, state: Any) -> tuple[np.ndarray, tuple[int, ...] | None]:
    """The task's own goals and switch steps (``None``: none defined) — the reference goals of
    PuckTrajectory, else the target as the one goal."""
    if hasattr(params, "switch_steps") and getattr(params, "goals", None) is not None:
        return (np.asarray(params.goals, np.float64),
                tuple(int(s) for s in np.asarray(params.switch_steps)))
    target = getattr(state, "target", None)
    if target is None:
        target = getattr(params, "target", None)
    if target is None:
        raise UsageError(f"{env.name} has no reference goals or target; give --goals")
    return np.asarray(target, np.float64).reshape(1, -1), None


def default_action_weight(env: Any, params: Any) -> float:
    """``r``: the reference controller's ``lqr_action_weight · force_max²`` on PuckTrajectory,
    :data:`PUCK_ACTION_WEIGHT` on other puck tasks, :data:`ARM_ACTION_WEIGHT` on the arm."""
    if hasattr(params, "switch_steps") and hasattr(params, "lqr_action_weight"):
        return float(params.lqr_action_weight) * float(params.force_max) ** 2
    return PUCK_ACTION_WEIGHT if hasattr(params, "force_max") else ARM_ACTION_WEIGHT


def resolve(task: str, goals: str | None = None, switch_times: str | None = None,
            horizon: int | None = None, action_weight: float | None = None,
            overrides: dict[str, Any] | None = None, seed: int = 0) -> Problem:
    """Build and validate the problem of the command line (nothing is compiled but the reset);
    raises :class:`UsageError` / ``ValueError`` with a message naming the bad value."""
    name = task_name(task)
    try:
        env, params = make(name, **(overrides or {}))
    except ValueError as e:
        raise UsageError(f"--set: {e}" if overrides else str(e)) from e
    _, state = env.reset(jax.random.PRNGKey(seed), params)
    if horizon is None:
        horizon = env.max_steps(params)
    if horizon < 1:
        raise UsageError(f"--horizon {horizon} must be >= 1 (the number of actions)")
    if action_weight is None:
        action_weight = default_action_weight(env, params)
    if not (math.isfinite(action_weight) and action_weight > 0):
        raise UsageError(f"--action-weight {action_weight} must be a finite number > 0 "
                         "(the box-QP needs a positive-definite Q_uu)")
    task_goals, task_switch = _task_defaults(env, params, state)
    if goals is None:
        goal_array, goal_label = task_goals, f"{name}'s goals"
    else:
        goal_array, goal_label = parse_goals(goals, env.goal_space.dim, name), f"--goals {goals!r}"
    check_goals(goal_array, env, goal_label)
    if switch_times is not None:
        times, label = parse_switch_times(switch_times), f"--switch-times {switch_times!r}"
    elif goals is None and task_switch is not None:
        times = task_switch
        label = f"{name}'s switch steps {list(task_switch)} (give --switch-times)"
    else:  # equal split of the horizon
        n = len(goal_array)
        times, label = tuple(i * horizon // n for i in range(1, n)), "the equal split"
        if len(set(times)) < len(times) or (times and times[0] < 1):
            raise UsageError(f"--horizon {horizon} is too short for {n} goals; give at "
                             f"least {n} actions")
    check_switch_times(times, len(goal_array), horizon, label)
    target = np.asarray(state.target) if name == "ArmReach" else None
    return Problem(name, env, params, state, int(horizon), goal_array, times,
                   float(action_weight), target)

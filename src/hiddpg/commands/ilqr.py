"""``hiddpg ilqr``: solve a task with iLQR, the paper's "standard controller" (Fig. 5).

    hiddpg ilqr PuckTrajectory2
    hiddpg ilqr PuckTrajectory2 --goals "1.2,-0.9;2.3,1.5" --switch-times 15 --json ilqr.json
    hiddpg ilqr PuckTrajectory3 --action-weight 0.03 --gif ilqr.gif
    hiddpg ilqr ArmObstacle --horizon 50 --set field=cw
    hiddpg ilqr ArmReach --seed 3 --goals "1.0,1.5"

iLQR (:func:`hiddpg.control.solve_task`) runs on the task's own differentiable dynamics
(``env.dynamics``) with the goal-tracking cost of spec ``algorithms.md`` §5,
``Σ_{k=1..T} |P x_k - g_k|² + r Σ_k |u_k|²`` (:func:`hiddpg.control.goal_tracking_cost`; ``P``
picks the goal entries of the task's goal space; ``u`` are the normalised actions, kept in the
action box by a box-QP). Defaults:

* PuckTrajectory1/2/3: the task's reference goals and switch steps, its horizon (30), and
  ``r = lqr_action_weight · force_max² = 3``: the reference controller's own effort weight in
  normalised actions, so that iLQR and the reference trade accuracy for effort alike;
* PuckObstacle, ArmObstacle, ArmReach: one goal, the task's target (ArmReach's is drawn as
  ``reset(PRNGKey(seed))`` draws it), the task's horizon; ``r = 0.01`` on the puck, ``0.001``
  on the arm. The obstacle is not part of the cost.

``--goals`` without ``--switch-times`` splits the horizon equally among the goals. The command
prints iterations, convergence, cost, the final state, the task's own return for the actions and
the cost after every iteration; ``--json`` writes states, actions and cost, ``--gif`` an
animation with the goals drawn. Parsed with tyro; a bad value prints one line naming it and what
is allowed, and exits with code 2 before anything is compiled.
"""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any

import jax
import jax.numpy as jnp
import numpy as np
import tyro

from hiddpg.envs import make, task_name

PROG = "hiddpg ilqr"
#: Default action weight ``r`` where the task has no reference controller [decision]:
#: normalised puck forces, and muscle activations (as in ``benchmarks/ilqr.py``).
PUCK_ACTION_WEIGHT = 0.01
ARM_ACTION_WEIGHT = 1e-3
#: GIF frame rate cap: the arm (50 control steps/s) plays at half speed.
MAX_FPS = 25.0


class UsageError(ValueError):
    """A bad command line: reported as one line, exit code 2."""


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
        """The :class:`~hiddpg.control.Cost` that :func:`solve` minimises."""
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


# -- solving ----------------------------------------------------------------------------------
def solve(problem: Problem):
    """iLQR on the problem (jitted): a :class:`~hiddpg.control.ILQRResult`."""
    from hiddpg.control import solve_task

    env, params = problem.env, problem.params

    @jax.jit
    def run(x0, goals):
        return solve_task(env, params, x0, problem.horizon, goals, problem.switch_times,
                          action_weight=problem.action_weight)

    return jax.block_until_ready(run(problem.state.x, jnp.asarray(problem.goals, jnp.float32)))


def env_rewards(problem: Problem, actions: Any) -> tuple[np.ndarray, int]:
    """The task's own rewards for the action sequence from the reset state, and the steps until
    the episode ends (terminated or truncated; the horizon if it does not)."""
    env, params = problem.env, problem.params

    @jax.jit
    def run(state, actions):
        def body(state, action):
            res = env.step(jax.random.PRNGKey(0), state, action, params)
            return res.state, (res.reward, res.terminated | res.truncated)

        return jax.lax.scan(body, state, actions)[1]

    rewards, done = jax.device_get(run(problem.state, jnp.asarray(actions)))
    steps = int(np.argmax(done)) + 1 if np.any(done) else len(done)
    return np.asarray(rewards, np.float64), steps


# -- output -----------------------------------------------------------------------------------
def _fmt(values: Any) -> str:
    return "[" + ", ".join(f"{float(v):.4g}" for v in np.ravel(values)) + "]"


def report(problem: Problem, result: Any, rewards: np.ndarray, steps: int) -> str:
    """The text the command prints."""
    history = np.asarray(result.cost_history)[: int(result.iterations) + 1]
    goals = "; ".join(_fmt(g) for g in problem.goals)
    lines = [
        f"iLQR on {problem.task}: {problem.horizon} actions, goals {goals}, switch times "
        f"{list(problem.switch_times)}, action weight {problem.action_weight:g}",
        f"iterations   {int(result.iterations)}",
        f"converged    {bool(result.converged)}",
        f"cost         {float(result.cost):.6g}",
        f"final state  {_fmt(result.states[-1])}",
        f"env return   {rewards[:steps].sum():.4f} over {steps} steps"
        + (" (the episode ended early)" if steps < problem.horizon else ""),
        "cost history (iteration: cost)",
        *(f"  {i:3d}: {c:.6g}" for i, c in enumerate(history)),
    ]
    return "\n".join(lines)


def to_json(problem: Problem, result: Any, rewards: np.ndarray, steps: int,
            overrides: dict[str, Any]) -> dict[str, Any]:
    """Everything needed to plot or re-check the solution (float32 values, exactly)."""
    as_list = lambda a: np.asarray(a, np.float64).tolist()  # noqa: E731
    history = np.asarray(result.cost_history)[: int(result.iterations) + 1]
    return {
        "task": problem.task, "overrides": overrides, "horizon": problem.horizon,
        "goals": as_list(problem.goals), "switch_times": list(problem.switch_times),
        "goal_indices": list(problem.env.goal_space.indices), "weight": 1.0,
        "action_weight": problem.action_weight,
        "iterations": int(result.iterations), "converged": bool(result.converged),
        "cost": float(result.cost), "cost_history": as_list(history),
        "final_state": as_list(result.states[-1]),
        "states": as_list(result.states), "actions": as_list(result.actions),
        "step_goals": as_list(problem.step_goals()),
        "rewards": as_list(rewards), "env_return": float(rewards[:steps].sum()),
        "episode_steps": steps,
    }


def write_gif(problem: Problem, result: Any, rewards: np.ndarray, path: Path) -> tuple[Path, int]:
    """Draw the solution with its goals (switch points marked); returns the path and frames."""
    from hiddpg import render

    env = problem.env
    title = f"iLQR on {problem.task}: cost {float(result.cost):.3f}"
    frames = render.render_rollout(
        env, problem.params, np.asarray(result.states), np.asarray(result.actions), rewards,
        goals=problem.step_goals(), title=title, target=problem.target,
    )
    return render.write_gif(frames, path, fps=min(1.0 / env.dt, MAX_FPS)), len(frames)


# -- command line -----------------------------------------------------------------------------
def _opt(metavar: str, help: str, hint: str = "") -> Any:
    """A tyro option with its help text and default hint."""
    return tyro.conf.arg(metavar=metavar, help=help, help_behavior_hint=hint or None)


def ilqr(
    task: Annotated[str, tyro.conf.Positional, tyro.conf.arg(
        metavar="TASK", help="a task name or id, e.g. PuckTrajectory2 or hiddpg/ArmObstacle-v0")],
    goals: Annotated[str | None, _opt(
        "'x,y;x,y'", "goals in the task's goal space (puck x, y; arm joint angles in rad); "
        "write --goals=... if it starts with a minus", "(default: the task's goals or target)",
    )] = None,
    switch_times: Annotated[str | None, _opt(
        "'15'", "action indices where the next goal starts: one fewer than the goals, "
        "increasing, in [1, horizon - 1]",
        "(default: the task's, or an equal split of the horizon with --goals)",
    )] = None,
    horizon: Annotated[int | None, _opt(
        "N", "number of actions", "(default: the task's horizon)")] = None,
    action_weight: Annotated[float | None, _opt(
        "W", "r in |P x - g|^2 + r |u|^2, u the normalised action",
        "(default: 3 on PuckTrajectory, 0.01 on PuckObstacle, 0.001 on the arm)")] = None,
    overrides: Annotated[tuple[str, ...], tyro.conf.arg(
        name="set", metavar="KEY=VALUE", help="an environment parameter, e.g. --set field=cw"),
        tyro.conf.UseAppendAction] = (),
    seed: Annotated[int, tyro.conf.arg(help="reset key (draws ArmReach's target)")] = 0,
    gif: Annotated[Path | None, _opt(
        "FILE", "write the solution as an animated GIF with the goals drawn", "(optional)")
    ] = None,
    json_path: Annotated[Path | None, tyro.conf.arg(
        name="json", metavar="FILE", help="write states, actions, cost and its history as JSON",
        help_behavior_hint="(optional)")] = None,
) -> int:
    """Solve TASK with iLQR on its own differentiable dynamics and print the solution."""
    from hiddpg.commands.envs import parse_overrides

    try:
        sets = parse_overrides(overrides)
        problem = resolve(task, goals, switch_times, horizon, action_weight, sets, seed)
    except ValueError as e:  # unknown task, bad --set (the env's messages name the field)
        raise UsageError(str(e)) from e
    result = solve(problem)
    rewards, steps = env_rewards(problem, result.actions)
    print(report(problem, result, rewards, steps))
    if json_path is not None:
        json_path.parent.mkdir(parents=True, exist_ok=True)
        data = to_json(problem, result, rewards, steps, sets)
        json_path.write_text(json.dumps(data, indent=1) + "\n")
        print(f"wrote {json_path}")
    if gif is not None:
        path, n = write_gif(problem, result, rewards, gif)
        print(f"wrote {path} ({n} frames)")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """``hiddpg ilqr``; returns the exit code (2 on a bad command line)."""
    args = list(sys.argv[1:] if argv is None else argv)
    try:
        return tyro.cli(ilqr, prog=PROG, args=args)
    except SystemExit as e:  # tyro's --help (0) and its usage errors (2)
        return e.code if isinstance(e.code, int) else 2
    except UsageError as e:
        message = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        print(f"{PROG}: error: {message}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

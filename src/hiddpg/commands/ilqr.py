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
animation with the goals drawn, the ``env_return`` so far and a legend. ``--gif`` must name a
file ending in ``.gif``; neither it nor ``--json`` may be an existing directory, and their
missing parent directories are created. Parsed with tyro; a bad value prints one line naming it
and what is allowed, and exits with code 2 before anything is compiled.

The problem is built and checked by :mod:`hiddpg.commands.ilqr_problem`, solved and shown by
:mod:`hiddpg.commands.ilqr_solution`; their names are re-exported here.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Annotated, Any

import tyro

from hiddpg.commands.common import UsageError, run_tyro
from hiddpg.commands.ilqr_problem import (
    ARM_ACTION_WEIGHT,
    PUCK_ACTION_WEIGHT,
    Problem,
    check_goals,
    check_switch_times,
    default_action_weight,
    parse_goals,
    parse_switch_times,
    resolve,
)
from hiddpg.commands.ilqr_solution import MAX_FPS, env_rewards, report, solve, to_json, write_gif
from hiddpg.paths import gif_path, output_file

__all__ = [
    "ARM_ACTION_WEIGHT", "MAX_FPS", "PROG", "PUCK_ACTION_WEIGHT", "Problem", "UsageError",
    "check_goals", "check_switch_times", "default_action_weight", "env_rewards", "ilqr", "main",
    "parse_goals", "parse_switch_times", "report", "resolve", "solve", "to_json", "write_gif",
]

PROG = "hiddpg ilqr"


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
        "FILE.gif", "write the solution as an animated GIF with the goals drawn (a name ending "
        "in .gif)", "(optional)")
    ] = None,
    json_path: Annotated[Path | None, tyro.conf.arg(
        name="json", metavar="FILE", help="write states, actions, cost and its history as JSON",
        help_behavior_hint="(optional)")] = None,
) -> int:
    """Solve TASK with iLQR on its own differentiable dynamics and print the solution."""
    from hiddpg.commands.envs import parse_overrides

    gif = None if gif is None else gif_path(gif, "--gif")
    json_path = None if json_path is None else output_file(json_path, "--json")
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
    return run_tyro(PROG, argv, lambda args: tyro.cli(ilqr, prog=PROG, args=args),
                    errors=(UsageError,))


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

"""The best plans of PuckTrajectory1/2/3 for the reference controller. A diagnostic, run by hand.

For each task: the reference plan (the goals and switch steps that drew the reference
trajectory) and, for each goal count, the best plan found
(:func:`hiddpg.experiments.plans.best_plans`), with the high-level return
``-Σ |p - p_ref| - c_switch (n - 1)`` each earns when the puck's reference (LQR) controller
carries it out. Shows whether the reference's switch count is the optimum at that switch cost.

Usage::

    python scripts/reference_plans.py [--switch-cost 10] [--max-goals 3]
"""

from __future__ import annotations

import argparse
import math

from hiddpg.envs import make as make_env
from hiddpg.experiments.plans import best_plans

TASKS = ("PuckTrajectory1", "PuckTrajectory2", "PuckTrajectory3")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--switch-cost", type=float, default=10.0)
    parser.add_argument("--max-goals", type=int, default=3)
    args = parser.parse_args()
    if not math.isfinite(args.switch_cost):
        parser.error(f"--switch-cost {args.switch_cost} must be a finite number")
    if not 1 <= args.max_goals <= 4:
        parser.error(f"--max-goals {args.max_goals} must be 1 to 4 (the search enumerates every "
                     "set of switch steps)")
    for task in TASKS:
        _, params = make_env(task)
        print(f"{task} (switch cost {args.switch_cost:g})")
        for plan in best_plans(params, args.max_goals, args.switch_cost):
            name = "reference" if plan["reference"] else f"best, {plan['n_goals']} goal(s)"
            goals = ", ".join(f"({x:.2f}, {y:.2f})" for x, y in plan["goals"])
            print(f"  {name:18s} return {plan['return']:8.2f}  tracking "
                  f"{plan['tracking']:7.2f}  switch steps {plan['switch_steps']}  goals {goals}")


if __name__ == "__main__":
    main()

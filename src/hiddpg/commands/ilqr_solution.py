"""Solving an ``hiddpg ilqr`` problem and showing the solution: the task's own return for its
actions, the printed report, the JSON record and the GIF."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from hiddpg.commands.ilqr_problem import Problem

#: GIF frame rate cap: the arm (50 control steps/s) plays at half speed.
MAX_FPS = 25.0


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
        f"env_return   {rewards[:steps].sum():.4f} over {steps} steps"
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
    """Draw the solution with its goals (switch points marked), the task's ``env_return`` so far
    and a legend; returns the path and the number of frames."""
    from hiddpg import render

    env = problem.env
    title = f"iLQR on {problem.task}: cost {float(result.cost):.3f}"
    frames = render.render_rollout(
        env, problem.params, np.asarray(result.states), np.asarray(result.actions), rewards,
        goals=problem.step_goals(), title=title, target=problem.target,
        goal_label="tracked goal",
    )
    return render.write_gif(frames, path, fps=min(1.0 / env.dt, MAX_FPS)), len(frames)

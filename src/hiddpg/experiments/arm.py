"""Fig. 6B: HI-DDPG moves the six-muscle arm around the obstacle to the target (ArmObstacle).

Left: one run's final noise-free episode, the arm drawn every few steps in a blue-green colour
map over time, its goals (joint space) as red arm postures, the obstacle and the target
posture. Right: the evaluation return over training, mean ± std over runs, with the low-level
pre-training phase (random goals, high level bypassed) shaded, and the fraction of runs that
succeed (hand within ``success_radius`` of the target at the end, no collision) after each
chunk. The drawn run is a successful one with the median return if any run succeeds, else the
run with the median return.
"""

from __future__ import annotations

import time
from collections.abc import Mapping

import jax
import numpy as np

from hiddpg.experiments import stats
from hiddpg.experiments.common import Context, ensure_run
from hiddpg.experiments.report import fmt, fmt_ci, fmt_pm, pyplot, save_figure, write_section
from hiddpg.experiments.rundata import RunData, load_run
from hiddpg.runner import seed_ranges

TASK = "ArmObstacle"
ALGO = "hi-ddpg"
POSTURES = 12
"""Arm postures drawn over the episode."""
MAX_LABELS = 10
"""Goals are numbered in the drawing when there are at most this many."""


def outcomes(traj: Mapping[str, np.ndarray], success_radius: float, horizon: int
             ) -> tuple[np.ndarray, np.ndarray]:
    """Per run: success (the last step's reward ``-distance`` is above ``-success_radius``, so
    no collision either) and collision (the episode ended before the horizon)."""
    alive = np.asarray(traj["alive"]).astype(bool)
    last = np.maximum(alive.sum(axis=1) - 1, 0)
    final_reward = np.asarray(traj["reward"])[np.arange(len(last)), last]
    return final_reward > -success_radius, alive.sum(axis=1) < horizon


def _task_constants(run: RunData) -> tuple[object, float, int]:
    env, params = run.env()
    return params, float(params.success_radius), env.max_steps(params)


def success_rates(runs: Mapping[str, RunData]) -> dict[str, float]:
    """Each method's fraction of successful runs in its final noise-free episode."""
    out = {}
    for label, run in runs.items():
        _, radius, horizon = _task_constants(run)
        ok, _ = outcomes(run.final_snapshot().traj, radius, horizon)
        out[label] = float(ok.mean())
    return out


def _drawn_run(success: np.ndarray, ret: np.ndarray) -> int:
    pool = np.flatnonzero(success) if success.any() else np.arange(len(ret))
    ordered = pool[np.argsort(ret[pool])]
    return int(ordered[(len(ordered) - 1) // 2])


def _draw_arm(ax, run: RunData, traj: Mapping[str, np.ndarray], i: int) -> list[np.ndarray]:
    from hiddpg.envs.arm import forward_kinematics

    plt = pyplot()
    params, _, _ = _task_constants(run)
    fk = jax.jit(jax.vmap(lambda th: forward_kinematics(th, params)))
    n = int(traj["alive"][i].sum())
    angles = np.concatenate([traj["obs"][i][:1, :2], traj["next_obs"][i][:n, :2]])
    joints = np.asarray(fk(angles))  # (n + 1, 3, 2)
    colours = plt.get_cmap("winter")(np.linspace(0, 1, POSTURES))
    steps = np.linspace(0, n, POSTURES).round().astype(int)
    for j, (c, k) in enumerate(zip(colours, steps, strict=True)):
        ax.plot(joints[k, :, 0], joints[k, :, 1], "-o", color=c, lw=2, ms=3,
                label=f"arm, {POSTURES} postures (blue: start, green: end)" if j == 0 else None)
    ax.plot(joints[:, 2, 0], joints[:, 2, 1], color="tab:cyan", lw=1, label="hand path")
    live = traj["alive"][i].astype(bool)
    goals = traj["goal"][i][np.flatnonzero(traj["switch"][i].astype(bool) & live)]
    goal_joints = np.asarray(fk(np.asarray(goals, np.float32)))
    numbered = len(goal_joints) <= MAX_LABELS
    for g, gj in enumerate(goal_joints):
        ax.plot(gj[:, 0], gj[:, 1], "-", color="tab:red", lw=1.5, alpha=0.8,
                label=("goals (numbered in order)" if numbered else "goals") if g == 0 else None)
        if numbered:
            ax.annotate(str(g + 1), gj[2], color="tab:red", fontsize=9)
    target = np.asarray(fk(np.asarray(params.target, np.float32)[None]))[0]
    ax.plot(target[:, 0], target[:, 1], "--", color="0.4", label="target posture")
    ax.add_patch(plt.Circle(np.asarray(params.obstacle_center), float(params.obstacle_diameter),
                            color="k", alpha=0.6, label="obstacle (collision zone)"))
    ax.set(aspect="equal", xlabel="x (m)", ylabel="y (m)")
    ax.legend(fontsize=7, loc="lower left")
    return list(goals)


def fig6(ctx: Context) -> dict:
    t0 = time.perf_counter()
    run = load_run(ensure_run(ctx, ALGO, TASK))
    _, radius, horizon = _task_constants(run)
    snaps = run.snapshots()
    final = run.final_snapshot()
    success, collision = outcomes(final.traj, radius, horizon)
    ret = final.metrics["env_return"]
    i = _drawn_run(success, ret)
    plt = pyplot()
    fig, (left, right) = plt.subplots(1, 2, figsize=(12, 5))
    goals = _draw_arm(left, run, final.traj, i)
    left.set_title(f"run {run.seeds[i]}, episode {final.episode}: "
                   f"{'success' if success[i] else 'no success'}, {len(goals)} goals")
    column = "eval_env_return" if run.has("eval_env_return") else "eval_return"
    episodes, values = run.series(column)
    mean, std = values.mean(axis=0), values.std(axis=0, ddof=1) if len(values) > 1 else 0
    right.plot(episodes, mean, color="tab:blue", label=f"{column}: mean of {len(values)} runs")
    right.fill_between(episodes, mean - std, mean + std, color="tab:blue", alpha=0.2, lw=0,
                       label="± std over runs")
    pretrain = int(getattr(run.config.agent, "pretrain_episodes", 0))
    if pretrain:
        right.axvspan(0, pretrain, color="0.85", label="low-level pre-training")
    right.set(xlabel="training episode", ylabel=f"noise-free evaluation ({column})")
    twin = right.twinx()
    rate = [outcomes(s.traj, radius, horizon)[0].mean() for s in snaps]
    twin.plot([s.episode for s in snaps], rate, "s-", color="tab:green", ms=3,
              label="success rate")
    twin.set(ylabel="success rate", ylim=(-0.05, 1.05))
    right.legend(fontsize=7, loc="upper left"), twin.legend(fontsize=7, loc="lower right")
    fig.suptitle("Fig. 6B: HI-DDPG on ArmObstacle")
    fig.tight_layout()
    figures = save_figure(fig, ctx.figure_stem("fig6"), ctx.note())
    summary = stats.summarize(ret)
    switches = final.metrics["switches"]
    numbers = {"success": success.tolist(), "collision": collision.tolist(),
               "success_rate": float(success.mean()), "collision_rate": float(collision.mean()),
               "final_eval_return": summary, "switches": switches.tolist(),
               "pretrain_episodes": pretrain, "episode": final.episode,
               "seeds": list(run.seeds), "drawn_seed": run.seeds[i],
               "drawn_goals_rad": np.asarray(goals).tolist()}
    markdown = "\n".join([
        f"Final noise-free episode of every run after {final.episode} episodes (the first "
        f"{pretrain} were low-level pre-training). Success: hand within {radius} m of the "
        "target at the end without collision.", "",
        "| runs | seeds | success rate | collision rate | eval return (mean ± std) | "
        "IQM [95% CI] | switches (mean ± std) |", "|---:|---|---:|---:|---:|---:|---:|",
        f"| {summary['n']} | {', '.join(seed_ranges(run.seeds))} | {fmt(success.mean())} | "
        f"{fmt(collision.mean())} | "
        f"{fmt_pm(summary['mean'], summary['std'])} | "
        f"{fmt_ci(summary['iqm'], summary['ci_low'], summary['ci_high'])} | "
        f"{fmt_pm(switches.mean(), switches.std(ddof=1) if len(switches) > 1 else np.nan)} |"])
    section = {"title": "Fig. 6B: the arm avoids the obstacle",
               "figures": [str(p.relative_to(ctx.out)) for p in figures],
               "markdown": markdown, "numbers": numbers, "wall_s": time.perf_counter() - t0}
    write_section(ctx, "fig6", section)
    return section

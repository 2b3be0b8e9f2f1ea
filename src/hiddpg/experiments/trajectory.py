"""Figs. 3-5: HI-DDPG following the reference trajectories of PuckTrajectory1/2/3.

* Fig. 3: the high-level return (environment return minus the switch cost) over training on
  the 2-inflection task, mean ± std over runs of each run's means over blocks of episodes
  (:class:`hiddpg.experiments.rundata.TrainingBlocks`), with the number of goal switches.
* Fig. 4: reference vs generated trajectories, the training history (one noise-free episode
  after every chunk) drawn with rising opacity; reference goals vs every run's learned goals.
* Fig. 5: one run's goals and low-level actions next to iLQR's actions for the same goals and
  switch times (the paper's "standard controller"), x and y separately.

Figures 4-5 draw the run with the median final return (not the best one); the numbers cover
every run.
"""

from __future__ import annotations

import time

import jax
import numpy as np

from hiddpg.experiments import stats
from hiddpg.experiments.common import Context, ensure_run
from hiddpg.experiments.report import fmt, fmt_ci, fmt_pm, pyplot, save_figure, write_section
from hiddpg.experiments.rundata import RunData, Snapshot, load_run
from hiddpg.runner import seed_ranges

ALGO = "hi-ddpg"
TASKS = ("PuckTrajectory1", "PuckTrajectory2", "PuckTrajectory3")
FIG3_TASK = "PuckTrajectory2"
FINAL_FRACTION = 0.1
"""Fig. 3's final return: each run's mean over the last 10% of its training blocks."""


def history_alpha(k: int, n: int) -> float:
    """Opacity of snapshot ``k`` of ``n`` (rising from 0.1 to 1; never above 1, which
    matplotlib rejects: 0.1 + 0.9 * 12 / 12 is 1.0000000000000002)."""
    return min(1.0, 0.1 + 0.9 * (k + 1) / n)


GOAL_RADIUS = 0.3
"""The reproduction's bar: every reference goal has a learned goal within this distance."""


def bar_counts(near: np.ndarray, switches: np.ndarray, reference_switches: int) -> dict:
    """Runs (rows of ``near``: distance from each reference goal to the nearest learned goal)
    whose goals all lie within :data:`GOAL_RADIUS`, whose switch count is the reference's,
    and both."""
    goals_ok = np.all(np.asarray(near) < GOAL_RADIUS, axis=1)
    switches_ok = np.asarray(switches) == reference_switches
    return {"runs": len(goals_ok), "goals": int(goals_ok.sum()),
            "switches": int(switches_ok.sum()), "both": int((goals_ok & switches_ok).sum())}


def bar_history(snaps: list[Snapshot], goals: np.ndarray, switch_steps: np.ndarray,
                horizon: int) -> list[tuple[int, int]]:
    """``(episode, runs meeting both parts of the bar)`` for each snapshot."""
    out = []
    for snap in snaps:
        near, _ = goal_distances(snap.traj, goals, switch_steps, horizon)
        both = bar_counts(near, snap.metrics["switches"], len(goals) - 1)["both"]
        out.append((snap.episode, both))
    return out


def _runs(ctx: Context, tasks: tuple[str, ...]) -> dict[str, RunData]:
    return {task: load_run(ensure_run(ctx, ALGO, task)) for task in tasks}


def _tasks(ctx: Context) -> tuple[str, ...]:
    return tuple(ctx.tasks) if ctx.tasks else TASKS


def _section(ctx: Context, name: str, title: str, figures, markdown: str, numbers: dict,
             t0: float) -> dict:
    section = {"title": title, "figures": [str(p.relative_to(ctx.out)) for p in figures],
               "markdown": markdown, "numbers": numbers, "wall_s": time.perf_counter() - t0}
    write_section(ctx, name, section)
    return section


def median_seed(snapshot: Snapshot) -> int:
    """Index of the run with the (lower) median final environment return."""
    ret = snapshot.metrics["env_return"]
    return int(np.argsort(ret)[(len(ret) - 1) // 2])


def positions(traj: dict[str, np.ndarray], i: int) -> np.ndarray:
    """Run ``i``'s positions from the start to after its last action, (steps + 1, 2)."""
    n = int(traj["alive"][i].sum())
    obs, nxt = traj["obs"][i], traj["next_obs"][i]
    return np.concatenate([obs[:1, :2], nxt[:n, :2]])


def learned_goals(traj: dict[str, np.ndarray], i: int) -> tuple[np.ndarray, np.ndarray]:
    """Run ``i``'s goals in the order chosen, (K, 2), and the steps where each started."""
    live = traj["alive"][i].astype(bool)
    steps = np.flatnonzero(traj["switch"][i].astype(bool) & live)
    return traj["goal"][i][steps], steps


def goal_distances(traj: dict[str, np.ndarray], goals: np.ndarray, switch_steps: np.ndarray,
                   horizon: int) -> tuple[np.ndarray, np.ndarray]:
    """(runs, reference goals) distances: to the nearest learned goal, and to the learned goal
    active at the middle of the reference goal's segment."""
    bounds = np.concatenate([[0], switch_steps, [horizon]])
    middle = (bounds[:-1] + bounds[1:] - 1) // 2
    nearest, at_segment = [], []
    for i in range(traj["goal"].shape[0]):
        mine, _ = learned_goals(traj, i)
        nearest.append(np.linalg.norm(goals[:, None] - mine[None], axis=-1).min(axis=1))
        at_segment.append(np.linalg.norm(traj["goal"][i][middle] - goals, axis=-1))
    return np.array(nearest), np.array(at_segment)


# ----------------------------------------------------------------------------------- Fig. 3


def fig3(ctx: Context) -> dict:
    t0 = time.perf_counter()
    run = _runs(ctx, (FIG3_TASK,))[FIG3_TASK]
    _, params = run.env()
    reference = len(np.asarray(params.goals)) - 1
    plt = pyplot()
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
    blocks = run.training
    ret, sw = blocks.means["return"], blocks.means["switches"]
    for ax, values, label in ((top, ret, "high-level return"), (bottom, sw, "goal switches")):
        mean, std = values.mean(axis=0), values.std(axis=0, ddof=1) if len(values) > 1 else 0
        ax.plot(blocks.ends, mean, color="tab:red", lw=1, label=f"mean over {len(values)} runs")
        ax.fill_between(blocks.ends, mean - std, mean + std, color="tab:red", alpha=0.2, lw=0,
                        label="± std over runs")
        ax.set_ylabel(label)
    bottom.axhline(reference, color="tab:blue", ls="--", label="reference's switches")
    top.set_title(f"Fig. 3: HI-DDPG on {FIG3_TASK}, training episodes\n(exploration on; "
                  f"means over blocks of {blocks.size} episodes)", fontsize=10)
    top.legend(fontsize=8), bottom.legend(fontsize=8)
    bottom.set_xlabel("training episode")
    figures = save_figure(fig, ctx.figure_stem("fig3"), ctx.note())
    tail = max(1, round(FINAL_FRACTION * ret.shape[1]))  # blocks
    final = stats.summarize(ret[:, -tail:].mean(axis=1))
    final_sw = run.final_snapshot().metrics["switches"]
    numbers = {"task": FIG3_TASK, "seeds": list(run.seeds), "final_high_level_return": final,
               "final_eval_switches": final_sw.tolist(), "reference_switches": reference}
    markdown = "\n".join([
        f"Final high-level return = each run's mean over its last {tail * blocks.size} "
        "training episodes.",
        "", "| runs | seeds | final high-level return (mean ± std) | IQM [95% CI] | "
            "switches, final policy (per run) | reference switches |",
        "|---:|---|---:|---:|---|---:|",
        f"| {final['n']} | {', '.join(seed_ranges(run.seeds))} | "
        f"{fmt_pm(final['mean'], final['std'])} | "
        f"{fmt_ci(final['iqm'], final['ci_low'], final['ci_high'])} | "
        f"{', '.join(str(int(s)) for s in final_sw)} | {reference} |"])
    return _section(ctx, "fig3", f"Fig. 3: high-level return on {FIG3_TASK}", figures,
                    markdown, numbers, t0)


# ----------------------------------------------------------------------------------- Fig. 4


def fig4(ctx: Context) -> dict:
    t0 = time.perf_counter()
    runs = _runs(ctx, _tasks(ctx))
    plt = pyplot()
    fig, axes = plt.subplots(len(runs), 2, figsize=(9, 3.6 * len(runs)), squeeze=False)
    numbers, rows, bars, history = {}, [], [], []
    for (task, run), (left, right) in zip(runs.items(), axes, strict=True):
        _, params = run.env()
        ref = np.concatenate([np.asarray(params.init_state)[None, :2],
                              np.asarray(params.ref_states)[:, :2]])
        goals, switch = np.asarray(params.goals), np.asarray(params.switch_steps)
        snaps = run.snapshots()
        final = snaps[-1]
        i = median_seed(final)
        for k, snap in enumerate(snaps):
            alpha = history_alpha(k, len(snaps))
            pos = positions(snap.traj, i)
            left.plot(pos[:, 0], pos[:, 1], color="tab:red", alpha=alpha, lw=1.5 if
                      k == len(snaps) - 1 else 0.8)
        left.plot(ref[:, 0], ref[:, 1], color="tab:blue", lw=2, label="reference")
        left.plot([], [], color="tab:red", label=f"generated (run {run.seeds[i]}, episodes "
                  f"{snaps[0].episode}-{final.episode}; fainter: earlier)")
        left.set(title=f"{task}: trajectories", xlabel="x", ylabel="y", aspect="equal")
        left.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.2))
        right.plot(ref[:, 0], ref[:, 1], color="tab:blue", lw=0.8, alpha=0.4,
                   label="reference trajectory")
        for j in range(final.traj["goal"].shape[0]):
            mine, _ = learned_goals(final.traj, j)
            right.scatter(mine[:, 0], mine[:, 1], s=60, color="tab:red", alpha=0.5,
                          label="learned goals (every run)" if j == 0 else None)
        right.scatter(goals[:, 0], goals[:, 1], s=120, color="tab:blue", alpha=0.7,
                      label="reference goals")
        right.set(title=f"{task}: goals", xlabel="x", ylabel="y", aspect="equal")
        right.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.2), ncol=2)
        near, seg = goal_distances(final.traj, goals, switch, params.max_steps)
        sw, ret = final.metrics["switches"], final.metrics["env_return"]
        numbers[task] = {"nearest_distance": near.tolist(), "segment_distance": seg.tolist(),
                         "switches": sw.tolist(), "reference_switches": len(goals) - 1,
                         "eval_env_return": final.metrics["env_return"].tolist(),
                         "episode": final.episode, "seeds": list(run.seeds),
                         "drawn_seed": run.seeds[i],
                         "bar": bar_counts(near, sw, len(goals) - 1),
                         "bar_history": bar_history(snaps, goals, switch, params.max_steps)}
        b = numbers[task]["bar"]
        history.append(f"| {task} | " + ", ".join(
            f"{e}: {n}" for e, n in numbers[task]["bar_history"]) + " |")
        bars.append(f"| {task} | {', '.join(seed_ranges(run.seeds))} | "
                    f"{b['goals']} / {b['runs']} | {b['switches']} / {b['runs']} | "
                    f"{b['both']} / {b['runs']} |")
        for g in range(len(goals)):
            rows.append(f"| {task} | {g + 1} ({goals[g, 0]:.2f}, {goals[g, 1]:.2f}) | "
                        f"{fmt_pm(near[:, g].mean(), _std(near[:, g]))} | "
                        f"{fmt_pm(seg[:, g].mean(), _std(seg[:, g]))} | "
                        f"{fmt_pm(sw.mean(), _std(sw))} | {len(goals) - 1} | "
                        f"{fmt_pm(ret.mean(), _std(ret))} |")
    fig.suptitle("Fig. 4: HI-DDPG trajectory following (history: rising opacity)")
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    figures = save_figure(fig, ctx.figure_stem("fig4"), ctx.note())
    markdown = "\n".join([
        "Distances are in position units, mean ± std over runs, for the final noise-free "
        "policy: to the nearest learned goal, and to the learned goal active at the middle of "
        "the reference goal's segment.", "",
        "| task | reference goal | distance, nearest | distance, in segment | switches | "
        "reference switches | eval return |", "|---|---|---:|---:|---:|---:|---:|", *rows, "",
        f"Runs that meet the bar (every reference goal has a learned goal within {GOAL_RADIUS}; "
        "the reference's switch count; the paper-scale target is both in 12 of 15 runs):", "",
        "| task | seeds | goals within 0.3 | switch count = reference | both |",
        "|---|---|---:|---:|---:|",
        *bars, "", "Runs that meet both over training (the noise-free snapshot after each "
        "chunk; episode: runs):", "", "| task | episode: runs meeting the bar |", "|---|---|",
        *history])
    return _section(ctx, "fig4", "Fig. 4: trajectories and goals", figures, markdown,
                    numbers, t0)


def _std(x: np.ndarray) -> float:
    return float(np.std(x, ddof=1)) if len(x) > 1 else float("nan")


# ----------------------------------------------------------------------------------- Fig. 5


def ilqr_actions(run: RunData, goals: np.ndarray, steps: np.ndarray) -> tuple[np.ndarray, bool]:
    """iLQR's (horizon, 2) actions tracking ``goals`` switched at ``steps`` from the start."""
    from hiddpg.control import solve_task

    env, params = run.env()
    horizon = env.max_steps(params)
    solve = jax.jit(lambda g, s: solve_task(env, params, params.init_state, horizon, g, s))
    result = solve(np.asarray(goals, np.float32), np.asarray(steps[1:], np.int32))
    return np.asarray(result.actions), bool(result.converged)


def fig5(ctx: Context) -> dict:
    t0 = time.perf_counter()
    runs = _runs(ctx, _tasks(ctx))
    plt = pyplot()
    fig, axes = plt.subplots(len(runs), 2, figsize=(10, 3 * len(runs)), squeeze=False,
                             sharex=True)
    numbers, rows = {}, []
    for (task, run), row in zip(runs.items(), axes, strict=True):
        final = run.final_snapshot()
        i = median_seed(final)
        n = int(final.traj["alive"][i].sum())
        goals, steps = learned_goals(final.traj, i)
        reference, converged = ilqr_actions(run, goals, steps)
        action, goal = final.traj["action"][i][:n], final.traj["goal"][i][:n]
        t = np.arange(n)
        for d, ax in enumerate(row):
            ax.step(t, goal[:, d], where="post", ls="--", color="tab:green", label="goal")
            ax.plot(t, action[:, d], color="tab:red", label="low-level action")
            ax.plot(t, reference[:n, d], ls=":", marker=".", color="k", label="iLQR action")
            ax.set_title(f"{task}, {'xy'[d]} (run {run.seeds[i]})", fontsize=9)
        row[0].legend(fontsize=7)
        rms = np.sqrt(np.mean((action - reference[:n]) ** 2, axis=0))
        numbers[task] = {"rms_x": float(rms[0]), "rms_y": float(rms[1]),
                         "ilqr_converged": converged, "switches": len(goals) - 1,
                         "drawn_seed": run.seeds[i]}
        rows.append(f"| {task} | {run.seeds[i]} | {len(goals) - 1} | {fmt(rms[0])} | "
                    f"{fmt(rms[1])} | {'yes' if converged else 'no'} |")
    for ax in axes[-1]:
        ax.set_xlabel("step")
    fig.suptitle("Fig. 5: goals (dashed), low-level actions (solid), iLQR (dotted)")
    fig.tight_layout(rect=(0, 0, 1, 0.96))
    figures = save_figure(fig, ctx.figure_stem("fig5"), ctx.note())
    markdown = "\n".join([
        "iLQR (the standard controller) tracks the drawn run's own goals with its switch "
        "times; RMS is the root-mean-square difference of the normalised actions.", "",
        "| task | run | switches | RMS x | RMS y | iLQR converged |",
        "|---|---:|---:|---:|---:|---|", *rows])
    return _section(ctx, "fig5", "Fig. 5: goals and actions vs iLQR", figures, markdown,
                    numbers, t0)

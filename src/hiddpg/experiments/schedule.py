"""The runs each figure of ``hiddpg reproduce`` needs, and what they cost.

Figures share runs (Figs. 3-5 the trajectory runs, Figs. 6 and 8 HI-DDPG on ArmObstacle), so
a run is trained once, by the first figure that needs it. :data:`CHEAP_FIRST` is the order
``reproduce all`` draws in: the puck figures before the arm's, whose runs take several times
longer (75 steps an episode, three-layer networks). :func:`plan_table` says, before anything
is trained, which runs an invocation trains, resumes or reuses and how many environment steps
are left (``reproduce --dry-run``).
"""

from __future__ import annotations

from dataclasses import dataclass

from hiddpg.experiments.common import Context
from hiddpg.experiments.parts import holds_finished
from hiddpg.runs import CONFIG_FILE, Run

#: The order ``reproduce all`` draws the figures in: cheap runs first.
CHEAP_FIRST = ("fig3", "fig4", "fig5", "fig7", "fig6", "fig8")


def figure_runs(ctx: Context, figure: str) -> list[tuple[str, str]]:
    """``(algo, task)`` of every run ``figure`` draws from."""
    from hiddpg.experiments import arm, comparison, trajectory

    if figure == "fig3":
        return [(trajectory.ALGO, trajectory.FIG3_TASK)]
    if figure in ("fig4", "fig5"):
        return [(trajectory.ALGO, t) for t in (ctx.tasks or trajectory.TASKS)]
    if figure == "fig6":
        return [(arm.ALGO, arm.TASK)]
    if figure in comparison.FIGURES:
        return [(algo, comparison.FIGURES[figure]) for algo in comparison.COMPARED]
    raise ValueError(f"unknown figure {figure!r}; choose one of {list(CHEAP_FIRST)}")


@dataclass(frozen=True)
class PlannedRun:
    """One run of an invocation: its budget, what is on disk, the steps left."""

    algo: str
    task: str
    figures: tuple[str, ...]
    seeds: int
    episodes: int
    done: int
    status: str
    """``new``, ``resume``, ``finished`` or ``failed``."""
    steps_left: int


def plan(ctx: Context, figures: tuple[str, ...] | list[str]) -> list[PlannedRun]:
    """Every run the figures need, in the order they are first trained."""
    from hiddpg.runs import make_trainer

    order: dict[tuple[str, str], list[str]] = {}
    for figure in figures:
        for key in figure_runs(ctx, figure):
            order.setdefault(key, []).append(figure)
    out = []
    for (algo, task), needed_by in order.items():
        config, seeds = ctx.config(algo, task), ctx.seed_list(task)
        path, done, status = ctx.run_path(algo, task), 0, "new"
        if holds_finished(ctx.artifact_path(algo, task), config, seeds, part=bool(ctx.part)):
            done, status = config.episodes, "finished"
        elif (path / CONFIG_FILE).is_file():
            run = Run.open(path)
            done, state = run.checkpoint_episodes(), run.progress().get("status")
            status = ("finished" if state == "finished" and done >= config.episodes
                      else "failed" if state == "failed" else "resume")
        trainer = make_trainer(config)
        horizon = trainer.env.max_steps(trainer.env_params)
        left = 0 if status in ("finished", "failed") else max(config.episodes - done, 0)
        out.append(PlannedRun(algo, task, tuple(needed_by), len(seeds), config.episodes, done,
                              status, left * len(seeds) * horizon))
    return out


def plan_table(runs: list[PlannedRun]) -> str:
    """The plan as a markdown table with a total."""
    rows = ["| run | figures | seeds | episodes | on disk | environment steps left |",
            "|---|---|---:|---:|---|---:|"]
    for r in runs:
        disk = {"new": "-", "finished": "finished", "failed": f"failed at {r.done}",
                "resume": f"resume at {r.done}"}[r.status]
        rows.append(f"| {r.algo} on {r.task} | {', '.join(r.figures)} | {r.seeds} | "
                    f"{r.episodes:,} | {disk} | {r.steps_left:,} |")
    rows.append(f"| total | | | | | {sum(r.steps_left for r in runs):,} |")
    return "\n".join(rows)

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


def figure_runs(ctx: Context, figure: str, planned: bool = False) -> list[tuple[str, str]]:
    """``(algo, task)`` of every run ``figure`` draws from; ``planned``: of every run it is
    meant to draw from (:attr:`Context.planned_tasks` where a redraw draws from fewer)."""
    from hiddpg.experiments import arm, comparison, trajectory

    if figure == "fig3":
        return [(trajectory.ALGO, trajectory.FIG3_TASK)]
    if figure in ("fig4", "fig5"):
        tasks = (ctx.planned_tasks if planned else None) or ctx.tasks or trajectory.TASKS
        return [(trajectory.ALGO, t) for t in tasks]
    if figure == "fig6":
        return [(arm.ALGO, arm.TASK)]
    if figure in comparison.FIGURES:
        return [(algo, comparison.FIGURES[figure]) for algo in comparison.COMPARED]
    raise ValueError(f"unknown figure {figure!r}; choose one of {list(CHEAP_FIRST)}")


def not_drawn(ctx: Context, figure: str) -> str | None:
    """Why ``reproduce all --algos`` passes over ``figure`` (one line), or ``None`` if it is
    drawn: a figure is passed over when the invocation trains none of its runs and one of them
    has no artifact, so there is nothing new to draw and drawing it would fail."""
    from hiddpg.experiments.common import available

    runs = figure_runs(ctx, figure)
    if ctx.algos is None or any(ctx.trains(algo) for algo, _ in runs):
        return None
    for algo, task in runs:
        if available(ctx, algo, task) is not None:
            return (f"{figure} passed over: --algos {','.join(ctx.algos)} trains none of its "
                    f"runs and {algo} on {task} has no artifact {ctx.artifact_path(algo, task)}")
    return None


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
    """Every run the figures need that this invocation trains (``ctx.algos``), in the order
    they are first trained."""
    from hiddpg.runs import make_trainer

    order: dict[tuple[str, str], list[str]] = {}
    for figure in figures:
        for key in figure_runs(ctx, figure):
            if ctx.trains(key[0]):
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


@dataclass(frozen=True)
class LeftRun:
    """What a run of an output still needs: the seeds it is meant to hold, those its artifact
    holds finished, the environment steps the rest take and the time they would take."""

    algo: str
    task: str
    planned: int
    held: tuple[int, ...]
    steps_left: int
    hours: float | None
    """At the rate of the output's finished runs of ``algo`` (``None``: none finished yet)."""
    rate_of: str
    """Whose rate ``hours`` uses: ``"run"`` (this algorithm on this task), ``algo`` (its runs
    on other tasks), ``"all"`` (every finished run's) or ``""`` (none)."""


def left(ctx: Context) -> list[LeftRun]:
    """Every run of every figure (:data:`CHEAP_FIRST`) with the seeds its artifact holds
    finished and what the others cost. A run's steps are ``seeds x episodes x horizon`` (an
    upper bound where episodes end early); its rate is the output's own, measured: the steps of
    its own finished seeds over their training time, else of the same algorithm's finished
    artifacts on other tasks (whose horizon and networks may differ), else of all algorithms'."""
    from hiddpg.envs.registry import make
    from hiddpg.experiments.artifacts import read_meta

    order: list[tuple[str, str]] = []
    for figure in CHEAP_FIRST:
        order += [key for key in figure_runs(ctx, figure, planned=True) if key not in order]
    rows, measured, own = [], {}, {}
    for algo, task in order:
        config = ctx.config(algo, task)
        env, params = make(task)
        per_seed = config.episodes * env.max_steps(params)
        artifact, held = ctx.artifact_path(algo, task), ()
        if artifact.is_dir():
            meta = read_meta(artifact)
            if meta.get("status") == "finished" and meta.get("episodes", 0) >= config.episodes:
                held = tuple(meta["seeds"])
                own[algo, task] = (per_seed * len(held), float(meta.get("wall_time") or 0.0))
                steps, seconds = measured.get(algo, (0, 0.0))
                measured[algo] = (steps + own[algo, task][0], seconds + own[algo, task][1])
        planned = ctx.seeds or ctx.budget(task).seeds
        rows.append((algo, task, planned, held, per_seed * len(set(range(planned)) - set(held))))
    everything = (sum(s for s, _ in measured.values()), sum(t for _, t in measured.values()))
    out = []
    for algo, task, planned, held, steps in rows:
        (steps_done, seconds), rate_of = own.get((algo, task), (0, 0.0)), "run"
        if not seconds:
            (steps_done, seconds), rate_of = measured.get(algo, (0, 0.0)), algo
        if not seconds:
            (steps_done, seconds), rate_of = everything, "all"
        hours = steps / (steps_done / seconds) / 3600 if seconds and steps_done else None
        out.append(LeftRun(algo, task, planned, held, steps, hours,
                           rate_of if hours is not None else ""))
    return out


def left_table(runs: list[LeftRun]) -> str:
    """:func:`left` as a markdown table with a total, or a line saying nothing is left."""
    from hiddpg.runner import seed_ranges

    if not any(r.steps_left for r in runs):
        return "Nothing: every run holds the seeds it is meant to."
    rows = ["| run | seeds planned | seeds held, finished | environment steps left | hours, "
            "at this output's rate |", "|---|---:|---|---:|---:|"]
    for r in runs:
        held = ", ".join(seed_ranges(list(r.held))) if r.held else "-"
        hours = ("0" if not r.steps_left else "-" if r.hours is None else
                 _hours(r.hours) + _whose(r))
        rows.append(f"| {r.algo} on {r.task} | {r.planned} | {held} | {r.steps_left:,} | "
                    f"{hours} |")
    known = [r.hours for r in runs if r.hours is not None]
    total = _hours(sum(known)) if len(known) == len(runs) else "-"
    rows.append(f"| total | | | {sum(r.steps_left for r in runs):,} | {total} |")
    return "\n".join(rows)


def _whose(r: LeftRun) -> str:
    """Whose rate an estimate uses, where it is not the run's own."""
    if r.rate_of == "all":
        return " (rate of all runs)"
    return "" if r.rate_of == "run" else f" (rate of {r.algo} on other tasks)"


def _hours(h: float) -> str:
    return f"{h:.1f}" if h >= 0.1 else "< 0.1"

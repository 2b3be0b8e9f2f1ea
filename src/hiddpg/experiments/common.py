"""What every paper reproduction shares: the context of an invocation, run-or-reuse, loading runs.

An experiment's output directory ``OUT`` holds::

    runs/<algo>-<task>/   run directories of `hiddpg train` (shared by the figures that use them)
        snapshots/episode_NNNNNN.npz   a noise-free evaluation episode per seed after each chunk
    artifacts/<algo>-<task>/  each run's artifact: what the figures read, small enough to
                              commit (:mod:`hiddpg.experiments.artifacts`)
    parts/<algo>-<task>/seeds-A-B/  with ``--part A-B``: the artifact of the run of those
                              seeds, merged into the run's artifact (:mod:`.parts`)
    artifacts/reproduce.json  what the invocation asked for (:mod:`hiddpg.experiments.redraw`)
    figures/figN.png|pdf  the figures
    sections/figN.json    each figure's numbers and report text (report.md is built from them)
    report.md             the numbers behind the figures

:func:`ensure_run` trains a run (:func:`hiddpg.runner.train_run`) only if it is not on disk:
a finished run, or a finished artifact holding its seeds, is reused as is, an interrupted run
is resumed from its last checkpoint, a run or artifact whose config differs from the one asked
for is an error (use another ``--out``); every run it returns has its artifact written. A
context ``from_artifacts`` (``hiddpg report``) trains nothing: :func:`ensure_run` returns the
artifact. This module is shell: files and the run loop, no plotting.
"""

from __future__ import annotations

import dataclasses
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from hiddpg import runner, summary
from hiddpg.algorithms import algorithm_names, get_algorithm
from hiddpg.configs import HIDDPGConfig, TrainConfig
from hiddpg.experiments.artifacts import ARTIFACTS_DIR, export_run, is_artifact
from hiddpg.experiments.budgets import (
    BUDGETS,
    DEFAULT_VARIANT,
    REPRODUCE_VARIANTS,
    SCALES,
    Budget,
    Variant,
    budget_group,
)
from hiddpg.experiments.parts import (
    PARTS_DIR,
    check_new_part,
    holds_finished,
    merge_parts,
    part_label,
)
from hiddpg.experiments.rundata import ExperimentError
from hiddpg.experiments.snapshots import SNAPSHOT_DIR, snapshot_name, write_snapshot
from hiddpg.presets import task_family
from hiddpg.reporter import ConsoleReporter
from hiddpg.runner import seed_ranges
from hiddpg.runs import CONFIG_FILE, Run, make_trainer

FAILED_FOR_GOOD = "non-finite"
"""A run stopped by a non-finite loss fails again on resume (training is deterministic)."""


@dataclass
class Context:
    """One ``hiddpg reproduce`` invocation: where, at what scale, which variant, with which
    overrides."""

    out: Path
    scale: str = "quick"
    variant: str | None = None
    """A name in :data:`REPRODUCE_VARIANTS`; ``None``: the scale's default."""
    seeds: int | None = None
    """Seeds per run (0..seeds-1); ``None``: the budget's."""
    episodes: int | None = None
    """Episodes per run for every task; ``None``: the budget's."""
    sets: tuple[str, ...] = ()
    """``--set key=value`` for every run; ``agent.hidden=[..]`` sets every hidden-size field."""
    tasks: tuple[str, ...] | None = None
    """Restrict the trajectory tasks (Figs. 4-5) to these (tests)."""
    planned_tasks: tuple[str, ...] | None = None
    """The trajectory tasks the output is meant to hold where Figs. 4-5 are drawn from fewer
    (:attr:`tasks`, a redraw's tasks with an artifact): what is still to train counts the
    others too; ``None``: :attr:`tasks`."""
    log: Any = field(default=None, repr=False)
    """Where progress lines go (default: the current ``sys.stderr``)."""
    from_artifacts: bool = False
    """Draw from ``out/artifacts`` only: no training, ``out/runs`` is never read."""
    described: str | None = None
    """The variant's description recorded with the artifacts; ``None``: its current one."""
    part: tuple[int, ...] | None = None
    """Train only these seeds of each run, as a run of their own whose artifact is merged
    with the other parts on disk (:mod:`hiddpg.experiments.parts`); ``None``: whole runs."""
    algos: tuple[str, ...] | None = None
    """Train only these algorithms' runs; a figure takes every other method from its
    artifact on disk, and leaves it out where there is none; ``None``: train every method."""

    def __post_init__(self) -> None:
        if self.scale not in SCALES:
            raise ValueError(f"scale={self.scale!r} must be one of {SCALES}")
        self.variant = self.variant or DEFAULT_VARIANT[self.scale]
        if self.variant not in REPRODUCE_VARIANTS:
            raise ValueError(f"variant={self.variant!r} must be one of "
                             f"{list(REPRODUCE_VARIANTS)}")
        if self.seeds is not None and self.seeds < 1:
            raise ValueError(f"seeds={self.seeds} must be >= 1")
        if self.part is not None:
            n = self.seeds or max(b.seeds for (s, _), b in BUDGETS.items() if s == self.scale)
            if not self.part or any(not 0 <= s < n for s in self.part):
                raise ValueError(f"part={list(self.part)} must be seeds of the runs' "
                                 f"0..{n - 1} ({n} seeds per run)")
            self.part = tuple(sorted(self.part))
        if self.algos is not None:
            known = algorithm_names()
            if not self.algos or any(a not in known for a in self.algos):
                raise ValueError(f"algos={list(self.algos)} must be one or more of "
                                 f"{list(known)}")
            self.algos = tuple(self.algos)
        self.out = Path(self.out)

    def trains(self, algo: str) -> bool:
        """Whether this invocation trains ``algo``'s runs (``algos``)."""
        return not self.from_artifacts and (self.algos is None or algo in self.algos)

    def say(self, message: str) -> None:
        print(message, file=self.log or sys.stderr, flush=True)

    @property
    def spec(self) -> Variant:
        return REPRODUCE_VARIANTS[self.variant]

    def budget(self, task: str) -> Budget:
        group = budget_group(task)
        return BUDGETS.get((self.scale, group)) or BUDGETS[(self.scale, task_family(task))]

    def note(self) -> str:
        """What every figure says it shows: the variant and the scale."""
        return f"variant {self.describe()} ({self.scale} scale)"

    def describe(self) -> str:
        return self.described or self.spec.describe()

    def seed_list(self, task: str) -> list[int]:
        """The seeds this invocation trains of a run on ``task`` (its part's, if any)."""
        return list(self.part or range(self.seeds or self.budget(task).seeds))

    def run_path(self, algo: str, task: str) -> Path:
        """The run directory this invocation trains (its part's, if any)."""
        suffix = f".{part_label(self.part)}" if self.part else ""
        return self.out / "runs" / f"{algo}-{task}{suffix}"

    def parts_path(self, algo: str, task: str) -> Path:
        """Where the parts of the run of ``algo`` on ``task`` keep their artifacts."""
        return self.out / PARTS_DIR / f"{algo}-{task}"

    def artifact_path(self, algo: str, task: str) -> Path:
        return self.out / ARTIFACTS_DIR / f"{algo}-{task}"

    def figure_stem(self, name: str) -> Path:
        return self.out / "figures" / name

    def train_sets(self, algo: str, task: str) -> list[str]:
        """The ``--set`` list of a run: budget, then the user's overrides."""
        from hiddpg.presets import make_config

        b, v, group = self.budget(task), self.spec, budget_group(task)
        episodes = (self.episodes or b.episodes
                    or (dict(v.paper_episodes).get(group) if self.scale == "paper" else None)
                    or make_config(algo, task, v.preset).episodes)
        sets = [f"episodes={episodes}", f"eval_every={min(b.eval_every, episodes)}",
                f"chunk_episodes={b.chunk_episodes}"]
        if get_algorithm(algo).config is HIDDPGConfig:
            sets += list(v.sets_for(group))
        return sets + expand_sets(make_config(algo, task, v.preset, sets), self.sets)

    def config(self, algo: str, task: str) -> TrainConfig:
        from hiddpg.presets import make_config

        return make_config(algo, task, self.spec.preset, self.train_sets(algo, task))


def expand_sets(config: TrainConfig, sets: tuple[str, ...] | list[str]) -> list[str]:
    """``agent.hidden=V`` becomes one ``--set`` per hidden-size field of ``config.agent``
    (``hidden`` or ``*_hidden`` at any depth), so one override fits every algorithm."""
    out: list[str] = []
    for item in sets:
        key, _, value = item.partition("=")
        if key.strip() != "agent.hidden":
            out.append(item)
            continue
        out += [f"agent.{path}={value}" for path in _hidden_paths(config.agent)]
    return out


def _hidden_paths(obj: Any, prefix: str = "") -> list[str]:
    paths = []
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        if dataclasses.is_dataclass(value):
            paths += _hidden_paths(value, f"{prefix}{f.name}.")
        elif f.name == "hidden" or f.name.endswith("_hidden"):
            paths.append(prefix + f.name)
    return paths


def available(ctx: Context, algo: str, task: str) -> str | None:
    """``None`` if ``algo``'s run on ``task`` is finished on disk or can be trained; else why
    not (one line), e.g. an algorithm without a preset or whose module does not import;
    from artifacts: ``None`` if its artifact is there."""
    if not ctx.trains(algo):
        path = ctx.artifact_path(algo, task)
        if is_artifact(path):
            return None
        return (f"no artifact {path}" if ctx.from_artifacts else
                f"not trained here (--algos {','.join(ctx.algos or ())}) and no artifact {path}")
    try:
        config = ctx.config(algo, task)
        path = ctx.run_path(algo, task)
        if (path / CONFIG_FILE).is_file():
            run = Run.open(path)
            if (run.progress().get("status") == "finished"
                    and run.checkpoint_episodes() == config.episodes):
                return None
        make_trainer(config)
    except (ValueError, TypeError, ImportError, AttributeError, KeyError) as err:
        return f"{type(err).__name__}: {err}"
    return None


# --------------------------------------------------------------------------- run or reuse


def ensure_run(ctx: Context, algo: str, task: str) -> Path:
    """The run directory of ``algo`` on ``task``, trained to its budget: reused if finished,
    resumed if interrupted, created otherwise; the last snapshot is made if missing, the
    artifact written. An artifact on disk that already holds the run's seeds, finished (a
    committed one, its run directory gone), is returned as it is. From artifacts: the artifact
    directory, nothing trained. With a part: the part's run is trained so, its artifact merged
    with the other parts', and the merged artifact returned."""
    if not ctx.trains(algo):
        if why := available(ctx, algo, task):
            raise ExperimentError(f"{why}; `hiddpg reproduce` writes it")
        if not ctx.from_artifacts:
            ctx.say(f"{ctx.artifact_path(algo, task)}: not in --algos, drawn from its artifact")
        return ctx.artifact_path(algo, task)
    artifact, config = ctx.artifact_path(algo, task), ctx.config(algo, task)
    path, seeds = ctx.run_path(algo, task), ctx.seed_list(task)
    if holds_finished(artifact, config, seeds, part=bool(ctx.part)):
        ctx.say(f"{artifact}: finished, reused (seeds {', '.join(seed_ranges(seeds))})")
        return artifact
    if ctx.part:
        check_new_part(ctx.parts_path(algo, task), ctx.part)
    if (path / CONFIG_FILE).is_file():
        run = Run.open(path)
        _check_same(run, config, seeds)
        done, progress = run.checkpoint_episodes(), run.progress()
        if progress.get("status") == "failed" and FAILED_FOR_GOOD in progress.get("error", ""):
            ctx.say(f"{path}: failed before ({progress['error']}); using its "
                    f"{done} episodes")
        elif done < config.episodes or progress.get("status") != "finished":
            ctx.say(f"{path}: resuming at episode {done} of {config.episodes}")
            if done and not (path / SNAPSHOT_DIR / snapshot_name(done)).is_file():
                write_snapshot(run)  # killed between its checkpoint and its snapshot
            _train(path, lambda: runner.open_for_resume(path, config.episodes))
        else:
            ctx.say(f"{path}: finished, reused")
    else:
        ctx.say(f"{path}: training {algo} on {task}, {len(seeds)} seeds, "
                f"{config.episodes} episodes")
        _train(path, lambda: runner.ReadyRun(runner.prepare_new(config, seeds, path),
                                             make_trainer(config), 0))
    run = Run.open(path)
    if not (path / SNAPSHOT_DIR / snapshot_name(run.checkpoint_episodes())).is_file():
        write_snapshot(run)
    if not ctx.part:
        export_run(path, artifact)
        return path
    export_run(path, ctx.parts_path(algo, task) / part_label(ctx.part))
    return merge_parts(ctx.parts_path(algo, task), artifact)


def _train(path: Path, open_run: Callable[[], runner.ReadyRun]) -> None:
    """Train the run ``open_run()`` creates or opens, a snapshot after every chunk; a run
    stopped by a non-finite loss is kept (the figures use its episodes so far)."""
    try:
        run, trainer, _ = open_run()
    except (ValueError, TypeError, FileNotFoundError) as err:
        raise ExperimentError(f"training {path} was refused: {err}") from None
    result = runner.train_run(run, trainer, on_chunk=lambda trained, _: write_snapshot(trained),
                              reporter=ConsoleReporter())
    if result.status == runner.INTERRUPTED:
        raise KeyboardInterrupt
    if result.status == runner.FAILED:
        print(f"warning: {path} stopped early ({result.error}); using its episodes so far",
              file=sys.stderr)
        return
    print(summary.result_line(run, result.wall_time))


def _check_same(run: Run, config: TrainConfig, seeds: list[int]) -> None:
    mine = dataclasses.replace(run.config, episodes=config.episodes)
    if mine != config or list(run.seeds) != seeds:
        diff = [f.name for f in dataclasses.fields(config)
                if getattr(mine, f.name) != getattr(config, f.name)]
        if list(run.seeds) != seeds:
            diff.append(f"seeds {list(run.seeds)} != {seeds}")
        raise ExperimentError(f"{run.path} holds a run with another config ({', '.join(diff)}); "
                              "remove it or choose another --out")

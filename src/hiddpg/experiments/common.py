"""What every paper reproduction shares: scales and budgets, run-or-reuse, loading runs.

An experiment's output directory ``OUT`` holds::

    runs/<algo>-<task>/   run directories of `hiddpg train` (shared by the figures that use them)
        snapshots/episode_NNNNNN.npz   a noise-free evaluation episode per seed after each chunk
    figures/figN.png|pdf  the figures
    sections/figN.json    each figure's numbers and report text (report.md is built from them)
    report.md             the numbers behind the figures

:func:`ensure_run` trains a run (:func:`hiddpg.runner.train_run`) only if it is not on disk:
a finished run is reused as is, an interrupted one is resumed from its last checkpoint, a run
whose config differs from the one asked for is an error (use another ``--out``). This module is
shell: files and the run loop, no plotting.
"""

from __future__ import annotations

import dataclasses
import io
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from hiddpg import runner, summary
from hiddpg.algorithms import get_algorithm
from hiddpg.configs import HIDDPGConfig, TrainConfig
from hiddpg.experiments.rundata import SNAPSHOT_DIR, ExperimentError
from hiddpg.presets import ARM_HIGH_CRITIC, CRITIC_DURATIONS
from hiddpg.reporter import ConsoleReporter
from hiddpg.runs import CONFIG_FILE, Run, atomic_write, make_trainer
from hiddpg.train import eval_keys

SCALES = ("quick", "paper")
FAILED_FOR_GOOD = "non-finite"
"""A run stopped by a non-finite loss fails again on resume (training is deterministic)."""
EVAL_KEY = 0
"""Evaluation key of the snapshots (that of ``hiddpg eval --key 0``)."""


@dataclass(frozen=True)
class Budget:
    """The training budget of one run (everything else is the preset's)."""

    preset: str
    seeds: int
    episodes: int
    eval_every: int
    chunk_episodes: int
    hi_ddpg_sets: tuple[str, ...] = ()
    """``--set`` overrides of the HI-DDPG runs (``hi-ddpg``, ``hi-ddpg-wo-model``)."""


#: (scale, task group: ``budget_group``) -> budget. ``quick``: the quick preset's own budget,
#: 3 seeds. ``paper``: the paper's 15 runs per method, trained with the quick preset's networks
#: and rates [decision; docs/results.md says why and what the paper preset gives].
BUDGETS: dict[tuple[str, str], Budget] = {
    ("quick", "puck"): Budget("quick", seeds=3, episodes=1500, eval_every=50,
                              chunk_episodes=250),
    ("quick", "arm"): Budget("quick", seeds=3, episodes=1500, eval_every=50,
                             chunk_episodes=250),
    ("paper", "puck"): Budget("quick", seeds=15, episodes=3000, eval_every=20,
                              chunk_episodes=250),
    ("paper", "trajectory"): Budget("quick", seeds=15, episodes=6000, eval_every=20,
                                    chunk_episodes=250, hi_ddpg_sets=CRITIC_DURATIONS),
    ("paper", "arm"): Budget("quick", seeds=15, episodes=3000, eval_every=20,
                             chunk_episodes=250, hi_ddpg_sets=ARM_HIGH_CRITIC),
}
"""At paper scale HI-DDPG on the trajectory tasks gets the critic-chosen durations
(``presets.CRITIC_DURATIONS``) and twice the paper's episodes, on ArmObstacle
``presets.ARM_HIGH_CRITIC`` [decision; docs/results.md]. A (scale, group) missing here falls back
to the task's family (``budget_group``)."""


GROUP_TASKS = {"trajectory": "PuckTrajectory1-3"}


def budget_group(scale: str, task: str) -> str:
    """The key of ``task``'s budget at ``scale``: ``"trajectory"`` (PuckTrajectory*) where
    that scale has its own, else the family (``"puck"`` or ``"arm"``)."""
    from hiddpg.envs import task_name
    from hiddpg.presets import SWITCHING_TASKS, task_family

    if task_name(task) in SWITCHING_TASKS and (scale, "trajectory") in BUDGETS:
        return "trajectory"
    return task_family(task)


def budget_table() -> str:
    """The budgets as a markdown table (README, report)."""
    rows = ["| scale | tasks | preset | seeds | episodes | eval every | chunk | HI-DDPG sets |",
            "|---|---|---|---:|---:|---:|---:|---|"]
    for (scale, group), b in BUDGETS.items():
        sets = " ".join(f"`{s}`" for s in b.hi_ddpg_sets) or "-"
        tasks = ("puck, but PuckTrajectory" if group == "puck" and (scale, "trajectory")
                 in BUDGETS else GROUP_TASKS.get(group, group))
        rows.append(f"| {scale} | {tasks} | {b.preset} | {b.seeds} | "
                    f"{b.episodes} | {b.eval_every} | {b.chunk_episodes} | {sets} |")
    return "\n".join(rows)


@dataclass
class Context:
    """One ``hiddpg reproduce`` invocation: where, at what scale, with which overrides."""

    out: Path
    scale: str = "quick"
    seeds: int | None = None
    """Seeds per run (0..seeds-1); ``None``: the budget's."""
    episodes: int | None = None
    """Episodes per run for every task; ``None``: the budget's."""
    sets: tuple[str, ...] = ()
    """``--set key=value`` for every run; ``agent.hidden=[..]`` sets every hidden-size field."""
    tasks: tuple[str, ...] | None = None
    """Restrict the trajectory tasks (Figs. 4-5) to these (tests)."""
    log: Any = field(default=None, repr=False)
    """Where progress lines go (default: the current ``sys.stderr``)."""

    def __post_init__(self) -> None:
        if self.scale not in SCALES:
            raise ValueError(f"scale={self.scale!r} must be one of {SCALES}")
        if self.seeds is not None and self.seeds < 1:
            raise ValueError(f"seeds={self.seeds} must be >= 1")
        self.out = Path(self.out)

    def say(self, message: str) -> None:
        print(message, file=self.log or sys.stderr, flush=True)

    def budget(self, task: str) -> Budget:
        return BUDGETS[(self.scale, budget_group(self.scale, task))]

    def seed_list(self, task: str) -> list[int]:
        return list(range(self.seeds or self.budget(task).seeds))

    def run_path(self, algo: str, task: str) -> Path:
        return self.out / "runs" / f"{algo}-{task}"

    def figure_stem(self, name: str) -> Path:
        return self.out / "figures" / name

    def train_sets(self, algo: str, task: str) -> list[str]:
        """The ``--set`` list of a run: budget, then the user's overrides."""
        from hiddpg.presets import make_config

        b = self.budget(task)
        episodes = self.episodes or b.episodes
        sets = [f"episodes={episodes}", f"eval_every={min(b.eval_every, episodes)}",
                f"chunk_episodes={b.chunk_episodes}"]
        if get_algorithm(algo).config is HIDDPGConfig:
            sets += list(b.hi_ddpg_sets)
        return sets + expand_sets(make_config(algo, task, b.preset, sets), self.sets)

    def config(self, algo: str, task: str) -> TrainConfig:
        from hiddpg.presets import make_config

        return make_config(algo, task, self.budget(task).preset, self.train_sets(algo, task))


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
    not (one line), e.g. an algorithm without a preset or whose module does not import."""
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
    resumed if interrupted, created otherwise; the last snapshot is made if missing."""
    path, config = ctx.run_path(algo, task), ctx.config(algo, task)
    seeds = ctx.seed_list(task)
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
    return path


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


# ------------------------------------------------------------------------------ snapshots


def snapshot_name(episodes: int) -> str:
    return f"episode_{episodes:06d}.npz"


def write_snapshot(run: Run) -> Path:
    """Evaluate the checkpointed policies (one noise-free episode per seed) and store metrics
    and trajectories in ``snapshots/episode_NNNNNN.npz``."""
    trainer = make_trainer(run.config)
    state, done = run.load_checkpoint(trainer)
    metrics, traj = trainer.evaluate_seeds(state, eval_keys(EVAL_KEY, run.seeds))
    arrays = {f"metric_{k}": np.asarray(v) for k, v in metrics.items()}
    arrays.update({f"traj_{k}": np.asarray(v) for k, v in traj.items()})
    buf = io.BytesIO()
    np.savez_compressed(buf, episode=np.asarray(done), **arrays)
    target = run.path / SNAPSHOT_DIR / snapshot_name(done)
    target.parent.mkdir(exist_ok=True)
    atomic_write(target, buf.getvalue())
    return target

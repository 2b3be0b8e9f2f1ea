"""The run loop: create or reopen a run directory, train it chunk by chunk, say how it ended.

``hiddpg train``, sweeps and the paper experiments all train through :func:`train_run`::

    run = prepare_new(config, parse_seeds("0-14"), "runs/mine")
    result = train_run(run, make_trainer(config), reporter=ConsoleReporter())
    # after a crash or an interrupt, or to extend the budget:
    run, trainer, done = open_for_resume("runs/mine", episodes=3000)
    result = train_run(run, trainer)

After every chunk the metrics are appended, TensorBoard is written and the loss metrics are
checked: a non-finite loss ends the run ``failed`` and keeps the last good checkpoint.
Otherwise the checkpoint and progress.json are written. A new run checkpoints its untrained
state first; a resumed one drops metrics rows past its checkpoint and runs exactly the chunks
an uninterrupted run would, so it ends with byte-identical files. Shell: I/O around
:class:`hiddpg.train.Trainer` and :class:`hiddpg.runs.Run`.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import NamedTuple

import numpy as np

from hiddpg.configs import TrainConfig
from hiddpg.reporter import Reporter
from hiddpg.run_check import apply_plan, find_non_finite, plan_resume
from hiddpg.run_files import RunFileError
from hiddpg.runs import Run, make_trainer
from hiddpg.stopping import on_stop
from hiddpg.train import RunState, Trainer

FINISHED, FAILED, INTERRUPTED = "finished", "failed", "interrupted"
#: ``on_chunk(run, episodes)``: called after each chunk's checkpoint and progress are written.
OnChunk = Callable[[Run, int], None]


@dataclass(frozen=True)
class RunResult:
    """How :func:`train_run` ended: ``status`` (finished, failed or interrupted), the episodes
    of the last checkpoint, the run's total wall time and, for a failure, its message."""

    status: str
    episodes: int
    wall_time: float
    error: str | None = None


class ReadyRun(NamedTuple):
    """A run directory ready for :func:`train_run`: the run, the trainer of its (possibly
    extended) config and the episodes its checkpoint holds."""

    run: Run
    trainer: Trainer
    done: int


def parse_seeds(text: str) -> list[int]:
    """``"0-14"`` -> 0..14, ``"0,3,5"`` -> [0, 3, 5], ``"7"`` -> [7]; parts may be mixed.
    Raises ``ValueError`` naming the text and the bad part."""
    seeds: list[int] = []
    for part in text.split(","):
        part = part.strip()
        lo, sep, hi = part.partition("-")
        try:
            a = int(lo)
            b = int(hi) if sep else a
        except ValueError:
            raise ValueError(f"seeds {text!r}: {part!r} is not a seed, a range like 0-14 or "
                             "a list like 0,3,5") from None
        if a > b:
            raise ValueError(f"seeds {text!r}: range {part!r} is empty (start {a} > end {b})")
        seeds.extend(range(a, b + 1))
    _check_seeds(seeds, repr(text))
    return seeds


def seed_ranges(seeds: Sequence[int]) -> list[str]:
    """The inverse of :func:`parse_seeds`, in order: 0..4 and 7 -> ``["0-4", "7"]``."""
    runs: list[list[int]] = []
    for s in sorted(int(s) for s in seeds):
        if runs and s == runs[-1][-1] + 1:
            runs[-1].append(s)
        else:
            runs.append([s])
    return [f"{r[0]}-{r[-1]}" if len(r) > 1 else f"{r[0]}" for r in runs]


def _check_seeds(seeds: list[int], text: str) -> None:
    if not seeds:
        raise ValueError(f"seeds {text}: give at least one seed")
    dup = sorted({s for s in seeds if seeds.count(s) > 1})
    if dup:
        raise ValueError(f"seeds {text}: seed(s) {dup} given twice")


def prepare_new(config: TrainConfig, seeds: Sequence[int], path: str | Path) -> Run:
    """Validate ``seeds`` and ``config`` (its env and agent are built, nothing is compiled),
    then create the run directory ``path``; nothing is written if a check fails.

    Raises ``ValueError`` for bad seeds or config, ``FileExistsError`` if ``path`` exists.
    """
    seeds = [int(s) for s in seeds]
    _check_seeds(seeds, str(seeds))
    make_trainer(config)
    path = Path(path)
    if path.exists():
        raise FileExistsError(f"run directory {path} exists")
    return Run.create(path, config, seeds)


def open_for_resume(path: str | Path, episodes: int | None = None) -> ReadyRun:
    """Open the run directory ``path`` to continue from its last good checkpoint, to
    ``episodes`` in all if given (the run's own budget otherwise). Nothing is compiled.

    The caller becomes the run's only writer (its lock is held until ``run.close()``). Every
    file is checked first (:func:`hiddpg.run_check.plan_resume`); only if the run can be
    continued is anything changed: a damaged checkpoint is moved aside and the previous one
    restored, a damaged progress.json rewritten, leftover temporary files removed. What was
    recovered is in ``run.notes``.

    Raises ``FileNotFoundError`` if ``path`` is not a run directory,
    :class:`~hiddpg.run_files.RunLockedError` if another process trains it,
    :class:`~hiddpg.run_files.RunFileError` (a ``ValueError``) naming a file that cannot be
    trusted, and ``ValueError`` if ``episodes`` is fewer than those done or the checkpoint
    is not at a chunk boundary.
    """
    run = Run.open(path)
    run.acquire()
    try:
        plan = plan_resume(run.checkpoint_path, run.previous_checkpoint_path, run.metrics_path,
                           run.seeds, run.state_shapes(make_trainer(run.config)))
        config, done = run.config, plan.episodes
        if episodes is not None:
            if episodes < done:
                raise ValueError(f"episodes {episodes} is fewer than the {done} episodes "
                                 f"{path} has done")
            config = dataclasses.replace(config, episodes=episodes)
        trainer = make_trainer(config)
        trainer.chunk_sizes(done)  # raises ValueError unless done is a chunk boundary
        run.notes += apply_plan(run, plan)
    except BaseException:
        run.release()
        raise
    return ReadyRun(run, trainer, done)


def train_run(run: Run, trainer: Trainer, *, on_chunk: OnChunk | None = None,
              reporter: Reporter | None = None) -> RunResult:
    """Train ``run`` from its last checkpoint (or its untrained state, checkpointed first) to
    ``trainer.config.episodes`` and mark how it ended in progress.json.

    The process becomes the run's only writer first (a
    :class:`~hiddpg.run_files.RunLockedError` if another one is). ``on_chunk(run, episodes)``
    is called after each chunk's checkpoint; ``reporter`` (default: silent) hears the
    progress. A non-finite loss returns status ``failed``. A ``KeyboardInterrupt`` (Ctrl-C in
    library use) returns ``interrupted``; under the ``hiddpg`` command a signal stops the
    process through :mod:`hiddpg.stopping`, which marks the run ``interrupted`` with the
    signal's name. Any other exception marks the run ``failed`` and propagates. Either way
    the run stays resumable from its last checkpoint; one that lands after the run is marked
    finished leaves it finished.
    """
    reporter = reporter if reporter is not None else Reporter()
    run.acquire()
    try:
        with on_stop(partial(mark_stopped, run, reporter=reporter)):
            state, done, wall = _start(run, trainer, reporter)
            return _train(run, trainer, state, done, wall, on_chunk, reporter)
    except BaseException as err:  # keep the last checkpoint's progress, mark the run
        episodes, wall = _last(run)
        if _finished(run):  # the interrupt landed after the run was marked finished
            if isinstance(err, KeyboardInterrupt):
                return RunResult(FINISHED, episodes, wall)
            raise
        if isinstance(err, KeyboardInterrupt):
            run.write_progress(episodes, wall, INTERRUPTED, signal="SIGINT",
                               error="KeyboardInterrupt")
            return RunResult(INTERRUPTED, episodes, wall)
        run.write_progress(episodes, wall, FAILED, error=repr(err))
        raise
    finally:
        run.close()


def _last(run: Run) -> tuple[int, float]:
    """Episodes and wall time of the last checkpoint, as progress.json says."""
    try:
        last = run.progress()
        return int(last["episodes"]), float(last["wall_time"])
    except (RunFileError, ValueError, TypeError):
        return run.checkpoint_episodes(), 0.0


def _finished(run: Run) -> bool:
    """Whether progress.json already says the run finished its configured budget (an
    extended run's earlier ``finished`` does not count)."""
    try:
        last = run.progress()
        return last["status"] == FINISHED and int(last["episodes"]) >= run.config.episodes
    except (RunFileError, ValueError, TypeError):
        return False


def mark_stopped(run: Run, signal_name: str, *, reporter: Reporter | None = None) -> None:
    """A signal stops the process (:mod:`hiddpg.stopping`): mark the run interrupted at its
    last checkpoint and give its lock up (a stop action; once the lock is given up, a second
    call does nothing). A run already marked finished stays finished."""
    if reporter is not None:
        reporter.close()
    if run.lock is None or not run.lock.held:
        return
    if not _finished(run):
        episodes, wall = _last(run)
        run.write_progress(episodes, wall, INTERRUPTED, signal=signal_name,
                           error=f"stopped by {signal_name}")
    run.release()


def _start(run: Run, trainer: Trainer, reporter: Reporter) -> tuple[RunState, int, float]:
    """The state to train from, episodes done and wall time so far; a run without a checkpoint
    checkpoints its untrained state first, so there is always a last good checkpoint."""
    resumed = run.checkpoint_path.is_file()
    if resumed:
        state, done = run.load_checkpoint(trainer)
    else:
        state, done = run.initial_state(trainer), 0
        run.save_checkpoint(state)
    if trainer.config != run.config:
        run.update_config(trainer.config)
    dropped = run.truncate_metrics(done)
    if resumed:
        reporter.resumed(run.path, done, dropped)
    for note in run.notes:
        reporter.note(note)
    run.notes = []
    return state, done, _last(run)[1]


def _train(run: Run, trainer: Trainer, state: RunState, done: int, wall: float,
           on_chunk: OnChunk | None, reporter: Reporter) -> RunResult:
    cfg = run.config
    reporter.start(f"{cfg.algo} {cfg.task}", cfg.episodes, done)
    try:
        for n in trainer.chunk_sizes(done):
            t0 = time.perf_counter()
            state, train_m, eval_m = trainer.run_chunk_seeds(state, n)
            train_m = {k: np.asarray(v) for k, v in train_m.items()}
            eval_m = {k: np.asarray(v) for k, v in eval_m.items()}
            elapsed = time.perf_counter() - t0
            wall += elapsed
            run.append_metrics(train_m, eval_m)
            run.write_tensorboard(train_m, eval_m)
            bad = find_non_finite(train_m, run.seeds)
            if bad:
                reporter.close()
                return _fail(run, done, wall, *bad)
            done += n
            run.save_checkpoint(state)
            run.write_progress(done, wall, "running")
            recent = train_m["return"][:, -min(n, cfg.eval_every):]
            reporter.update(done, train_return=float(recent.mean()),
                            eval_return=float(eval_m["return"][:, -1].mean()),
                            steps_per_s=float(train_m["length"].sum() / elapsed))
            if on_chunk is not None:
                on_chunk(run, done)
    finally:
        reporter.close()
    run.write_progress(done, wall, FINISHED)
    return RunResult(FINISHED, done, wall)


def _fail(run: Run, done: int, wall: float, metric: str, seed: int, episode: int) -> RunResult:
    msg = (f"non-finite {metric} for seed {seed} at episode {episode}; training stopped. "
           f"Last good checkpoint (episode {done}): {run.checkpoint_path}")
    run.write_progress(done, wall, FAILED, error=msg)
    return RunResult(FAILED, done, wall, msg)

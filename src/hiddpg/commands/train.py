"""``hiddpg train``: train one algorithm on one task for many seeds at once, or resume a run.

::

    hiddpg train ALGO TASK [--seeds 0-14] [--episodes N] [--preset paper|quick]
                 [--set key=value ...] [--out DIR] [--name NAME]
    hiddpg train --resume DIR [--episodes N]

Every config error (unknown algorithm, task or ``--set`` key, a value out of range, bad seeds)
is one line on stderr and exit code 2, before anything is compiled or written. After every
chunk the metrics are appended, TensorBoard is written and the loss metrics are checked: a
non-finite loss stops the run with exit code 1 and keeps the last good checkpoint.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from hiddpg.commands.common import Parser as _Parser
from hiddpg.commands.common import UsageError, argv_or_help
from hiddpg.configs import ALGORITHMS
from hiddpg.runs import Run, default_name, find_non_finite, make_trainer

PROG = "hiddpg train"




def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog=PROG, description="Train ALGO on TASK for several seeds at once "
                "(one jitted, vmapped run); results go to OUT/NAME/.")
    p.add_argument("algo", nargs="?", metavar="ALGO", help=f"one of {', '.join(ALGORITHMS)}")
    p.add_argument("task", nargs="?", metavar="TASK",
                   help="a task, e.g. PuckTrajectory2 (see `hiddpg envs list`)")
    p.add_argument("--seeds", default=None,
                   help="seeds: a range '0-14', a list '0,3,5' or one '7' (default 0-14)")
    p.add_argument("--episodes", type=int, default=None,
                   help="training episodes per seed (default: the preset's)")
    p.add_argument("--preset", default=None, help="paper (default) or quick")
    p.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE",
                   help="override a config field, e.g. agent.hidden=[64,64] (repeatable)")
    p.add_argument("--out", default="runs", help="parent directory of runs (default runs/)")
    p.add_argument("--name", default=None, help="run name (default ALGO-TASK-TIMESTAMP)")
    p.add_argument("--resume", default=None, metavar="DIR",
                   help="continue the run in DIR from its last checkpoint")
    return p


def parse_seeds(text: str) -> list[int]:
    """``"0-14"`` -> 0..14, ``"0,3,5"`` -> [0, 3, 5], ``"7"`` -> [7]; parts may be mixed."""
    seeds: list[int] = []
    for part in text.split(","):
        part = part.strip()
        lo, sep, hi = part.partition("-")
        try:
            a = int(lo)
            b = int(hi) if sep else a
        except ValueError:
            raise UsageError(f"--seeds {text!r}: {part!r} is not a seed, a range like 0-14 or "
                             "a list like 0,3,5") from None
        if a > b:
            raise UsageError(f"--seeds {text!r}: range {part!r} is empty (start {a} > end {b})")
        seeds.extend(range(a, b + 1))
    dup = sorted({s for s in seeds if seeds.count(s) > 1})
    if dup:
        raise UsageError(f"--seeds {text!r}: seed(s) {dup} given twice")
    return seeds


def _prepare(args: argparse.Namespace):
    """Validate everything and return ``(run or path, config, seeds, trainer)``; no run
    directory exists for a new run yet and nothing has been compiled."""
    from hiddpg.presets import make_config

    if args.resume:
        given = [n for n, v in (("ALGO", args.algo), ("TASK", args.task), ("--name", args.name),
                                ("--set", args.sets), ("--seeds", args.seeds),
                                ("--preset", args.preset)) if v]
        if given:
            raise UsageError(f"--resume takes the run's config from {args.resume}; "
                             f"drop {', '.join(given)}")
        run = Run.open(args.resume)
        config, done = run.config, run.checkpoint_episodes()
        if args.episodes is not None:
            if args.episodes < done:
                raise UsageError(f"--episodes {args.episodes} is fewer than the {done} "
                                 f"episodes {args.resume} has done")
            config = dataclasses.replace(config, episodes=args.episodes)
        trainer = make_trainer(config)
        trainer.chunk_sizes(done)  # raises ValueError unless done is a chunk boundary
        return run, config, list(run.seeds), trainer
    if not args.algo or not args.task:
        raise UsageError("ALGO and TASK are required (or --resume DIR)")
    seeds = parse_seeds(args.seeds or "0-14")
    sets = list(args.sets) + ([f"episodes={args.episodes}"] if args.episodes is not None else [])
    config = make_config(args.algo, args.task, args.preset or "paper", sets)
    trainer = make_trainer(config)  # builds env and agent: validates env overrides
    path = Path(args.out) / (args.name or default_name(config.algo, config.task))
    if path.exists():
        raise UsageError(f"run directory {path} exists; choose another --name or --resume it")
    return path, config, seeds, trainer


def main(argv: Sequence[str] | None = None,
         on_chunk: Callable[[Run, int], None] | None = None) -> int:
    """Run ``hiddpg train`` with ``argv``; returns the exit code. ``on_chunk(run, episodes)``
    is called after each chunk's checkpoint is written (tests use it to simulate a crash)."""
    argv = argv_or_help(argv, build_parser)
    if argv is None:
        return 0
    try:
        args = build_parser().parse_args(argv)
        target, config, seeds, trainer = _prepare(args)
    except (UsageError, ValueError, TypeError, FileNotFoundError) as err:
        print(f"{PROG}: error: {err}", file=sys.stderr)
        return 2
    run = target if isinstance(target, Run) else Run.create(target, config, seeds)
    try:
        state, done, wall = _start(run, trainer, resumed=isinstance(target, Run))
        return _train(run, trainer, state, done, wall, on_chunk)
    except BaseException as err:  # keep the last checkpoint's progress, mark the run
        last = run.progress()
        stopped = isinstance(err, KeyboardInterrupt)  # Ctrl-C or SIGTERM (hiddpg.cli)
        run.write_progress(last["episodes"], last["wall_time"],
                           "interrupted" if stopped else "failed", error=repr(err))
        if stopped:
            print(f"{PROG}: interrupted; continue with: hiddpg train --resume {run.path}",
                  file=sys.stderr)
            return 130
        raise
    finally:
        run.close()


def _start(run: Run, trainer, resumed: bool):
    """The state to train from, episodes done and wall time so far; a new run's untrained
    state is checkpointed first, so there is always a last good checkpoint."""
    if not resumed:
        state = run.initial_state(trainer)
        run.save_checkpoint(state)
        return state, 0, 0.0
    state, done = run.load_checkpoint(trainer)
    if trainer.config != run.config:
        run.update_config(trainer.config)
    dropped = run.truncate_metrics(done)
    print(f"resuming {run.path} at episode {done}"
          + (f" (dropped {dropped} metrics rows past the checkpoint)" if dropped else ""),
          file=sys.stderr)
    return state, done, float(run.progress().get("wall_time", 0.0))


def _train(run: Run, trainer, state, done: int, wall: float, on_chunk) -> int:
    cfg = run.config
    with _Reporter(f"{cfg.algo} {cfg.task}", cfg.episodes, done) as report:
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
                report.close()
                return _fail(run, done, wall, *bad)
            done += n
            run.save_checkpoint(state)
            run.write_progress(done, wall, "running")
            recent = train_m["return"][:, -min(n, cfg.eval_every):]
            report.update(done, ret=f"{recent.mean():.2f}",
                          eval=f"{eval_m['return'][:, -1].mean():.2f}",
                          sps=f"{train_m['length'].sum() / elapsed:,.0f}")
            if on_chunk is not None:
                on_chunk(run, done)
    run.write_progress(done, wall, "finished")
    print(result_line(run, wall))
    return 0


class _Reporter:
    """A rich progress bar on a terminal; one plain line per chunk otherwise (logs, CI)."""

    def __init__(self, title: str, total: int, done: int) -> None:
        from rich.console import Console

        self.title, self.total = title, total
        self.console = Console(stderr=True)
        self.bar = None
        if self.console.is_terminal:
            from rich.progress import (
                BarColumn,
                MofNCompleteColumn,
                Progress,
                TextColumn,
                TimeElapsedColumn,
            )

            self.bar = Progress(
                TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
                TextColumn("return {task.fields[ret]}  eval {task.fields[eval]}  "
                           "{task.fields[sps]} env steps/s"),
                TimeElapsedColumn(), console=self.console)
            self.task = self.bar.add_task(title, total=total, completed=done,
                                          ret="-", eval="-", sps="-")

    def __enter__(self) -> _Reporter:
        if self.bar is not None:
            self.bar.start()
        return self

    def update(self, done: int, *, ret: str, eval: str, sps: str) -> None:
        if self.bar is not None:
            self.bar.update(self.task, completed=done, ret=ret, eval=eval, sps=sps)
        else:
            print(f"{self.title}  episode {done}/{self.total}  return {ret}  eval {eval}  "
                  f"{sps} env steps/s", file=sys.stderr, flush=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.stop()

    def __exit__(self, *exc: object) -> None:
        self.close()


def _fail(run: Run, done: int, wall: float, metric: str, seed: int, episode: int) -> int:
    ckpt = run.checkpoint_path
    msg = (f"non-finite {metric} for seed {seed} at episode {episode}; training stopped. "
           f"Last good checkpoint (episode {done}): {ckpt}")
    run.write_progress(done, wall, "failed", error=msg)
    print(f"{PROG}: error: {msg}", file=sys.stderr)
    return 1


def result_line(run: Run, wall: float) -> str:
    """``final eval return M ± S over N seeds | wall T s | run DIR`` (S: sample std)."""
    finals = np.array(list(run.final_eval().values()), dtype=np.float64)
    if finals.size:
        std = finals.std(ddof=1) if finals.size > 1 else 0.0
        score = f"final eval return {finals.mean():.3f} ± {std:.3f} over {finals.size} seeds"
    else:
        score = "no evaluation recorded"
    return f"{score} | wall {wall:.1f} s | run {run.path}"


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

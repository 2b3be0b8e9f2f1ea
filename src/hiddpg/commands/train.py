"""``hiddpg train``: train one algorithm on one task for many seeds at once, or resume a run.

::

    hiddpg train ALGO TASK [--seeds 0-14] [--episodes N] [--preset paper|quick]
                 [--set key=value ...] [--out DIR] [--name NAME]
    hiddpg train --resume DIR [--episodes N]

Every config error (unknown algorithm, task or ``--set`` key, a value out of range, bad seeds)
is one line on stderr and exit code 2, before anything is compiled or written. After every
chunk the metrics are appended, TensorBoard is written and the loss metrics are checked: a
non-finite loss stops the run with exit code 1 and keeps the last good checkpoint; Ctrl-C or
SIGTERM stops it with exit code 130. The loop itself is :func:`hiddpg.runner.train_run`.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

from hiddpg.algorithms import algorithm_names
from hiddpg.commands.common import Parser as _Parser
from hiddpg.commands.common import UsageError, argv_or_help
from hiddpg.reporter import ConsoleReporter
from hiddpg.runner import (
    FAILED,
    INTERRUPTED,
    open_for_resume,
    parse_seeds,
    prepare_new,
    result_line,
    train_run,
)
from hiddpg.runs import Run, default_name, make_trainer
from hiddpg.train import Trainer

PROG = "hiddpg train"


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog=PROG, description="Train ALGO on TASK for several seeds at once "
                "(one jitted, vmapped run); results go to OUT/NAME/.")
    p.add_argument("algo", nargs="?", metavar="ALGO",
                   help=f"one of {', '.join(algorithm_names())}")
    p.add_argument("task", nargs="?", metavar="TASK",
                   help="a task, e.g. PuckTrajectory2 (see `hiddpg envs list`), or your "
                   "environment as module:Class (imported and registered)")
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


def _as_flag(err: ValueError, name: str) -> UsageError:
    """The library names a bad value by its parameter (``seeds '0,x': ...``); the command
    line names the flag that gave it (``--seeds '0,x': ...``)."""
    text = str(err)
    return UsageError(f"--{text}" if text.startswith(f"{name} ") else text)


def _prepare(args: argparse.Namespace) -> tuple[Run, Trainer]:
    """Validate the command line, then create or open the run directory; nothing is written
    if a check fails and nothing is compiled."""
    from hiddpg.presets import make_config

    if args.resume:
        given = [n for n, v in (("ALGO", args.algo), ("TASK", args.task), ("--name", args.name),
                                ("--set", args.sets), ("--seeds", args.seeds),
                                ("--preset", args.preset)) if v]
        if given:
            raise UsageError(f"--resume takes the run's config from {args.resume}; "
                             f"drop {', '.join(given)}")
        try:
            run, trainer, _ = open_for_resume(args.resume, args.episodes)
        except ValueError as err:
            raise _as_flag(err, "episodes") from None
        return run, trainer
    if not args.algo or not args.task:
        raise UsageError("ALGO and TASK are required (or --resume DIR)")
    try:
        seeds = parse_seeds(args.seeds or "0-14")
    except ValueError as err:
        raise _as_flag(err, "seeds") from None
    sets = list(args.sets) + ([f"episodes={args.episodes}"] if args.episodes is not None else [])
    config = make_config(args.algo, args.task, args.preset or "paper", sets)
    trainer = make_trainer(config)  # builds env and agent: validates env overrides
    path = Path(args.out) / (args.name or default_name(config.algo, config.task))
    try:
        return prepare_new(config, seeds, path), trainer
    except FileExistsError as err:
        raise UsageError(f"{err}; choose another --name or --resume it") from None


def main(argv: Sequence[str] | None = None,
         on_chunk: Callable[[Run, int], None] | None = None) -> int:
    """Run ``hiddpg train`` with ``argv``; returns the exit code. ``on_chunk(run, episodes)``
    is called after each chunk's checkpoint is written (tests use it to simulate a crash)."""
    argv = argv_or_help(argv, build_parser)
    if argv is None:
        return 0
    try:
        args = build_parser().parse_args(argv)
        run, trainer = _prepare(args)
    except (UsageError, ValueError, TypeError, FileNotFoundError) as err:
        print(f"{PROG}: error: {err}", file=sys.stderr)
        return 2
    result = train_run(run, trainer, on_chunk=on_chunk, reporter=ConsoleReporter())
    if result.status == INTERRUPTED:
        print(f"{PROG}: interrupted; continue with: hiddpg train --resume {run.path}",
              file=sys.stderr)
        return 130
    if result.status == FAILED:
        print(f"{PROG}: error: {result.error}", file=sys.stderr)
        return 1
    print(result_line(run, result.wall_time))
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

"""``hiddpg train``: train one algorithm on one task for many seeds at once, or resume a run.

::

    hiddpg train ALGO TASK [--preset quick|paper|paper+] [--seeds S] [--episodes N]
                 [--set key=value ...] [--out DIR] [--name NAME]
                 [--goal INDEX:LOW:HIGH ...] [--skills MODULE:FUNCTION]
    hiddpg train --resume DIR [--episodes N]

A bare ``hiddpg train ALGO TASK`` trains the quick preset on seeds 0-4 (minutes);
``--preset paper`` (or ``paper+``) is the paper's budget on its 15 seeds 0-14 (hours on two
cores). Before training the run says what it will do (seeds, episodes, environment steps,
checkpoint size) and, after its first chunk, how long it will take.

A Gymnasium environment is a TASK too (``gym:<id>``, a bare id, or ``module:Env-v0``): it
trains on the host-loop engine (:mod:`hiddpg.host`) with the preset's generic values;
``--goal`` declares HI-DDPG's goal entries and ``--skills`` h-DDPG's skills
(:mod:`hiddpg.host.declare`), recorded in the run directory for ``--resume`` and ``eval``.

Every config or path error (unknown algorithm, task or ``--set`` key, a value out of range,
bad seeds, a ``--name`` that is not a plain name) is one line on stderr and exit code 2,
before anything is compiled or written. A run another process is training, or whose files
cannot be trusted, is refused with exit code 1 and a message saying what to do. A non-finite
loss stops the run with exit code 1 and keeps the last good checkpoint. SIGTERM and Ctrl-C
stop it at once with exit code 143 and 130, the run marked ``interrupted`` at its last
checkpoint (:mod:`hiddpg.stopping`). The loop itself is :func:`hiddpg.runner.train_run`.
"""

from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Callable, Sequence

from hiddpg.algorithms import algorithm_names
from hiddpg.commands.common import Parser as _Parser
from hiddpg.commands.common import UsageError, argv_or_help
from hiddpg.host.declare import (
    declarations_scope,
    declare,
    directory_name,
    record_sources,
    sources_line,
    value_sources,
)
from hiddpg.host.task import is_gym_task
from hiddpg.paths import existing_dir, output_dir
from hiddpg.plan import describe
from hiddpg.reporter import ConsoleReporter
from hiddpg.run_files import RunFileError, RunLockedError
from hiddpg.runner import (
    FAILED,
    FINISHED,
    INTERRUPTED,
    mark_stopped,
    open_for_resume,
    parse_seeds,
    prepare_new,
    train_run,
)
from hiddpg.runs import Run, default_name, make_trainer
from hiddpg.stopping import on_stop
from hiddpg.summary import final_evaluation, result_line, score_text
from hiddpg.train import Trainer

PROG = "hiddpg train"


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog=PROG, description="Train ALGO on TASK for several seeds at once "
                "(one jitted, vmapped run); results go to OUT/NAME/.")
    p.add_argument("algo", nargs="?", metavar="ALGO",
                   help=f"one of {', '.join(algorithm_names())}")
    p.add_argument("task", nargs="?", metavar="TASK",
                   help="a task, e.g. PuckTrajectory2 (see `hiddpg envs list`), your "
                   "environment as module:Class (imported and registered), or a Gymnasium "
                   "environment: gym:<id>, a bare id (Reacher-v5) or module:Env-v0, trained "
                   "on the host-loop engine")
    p.add_argument("--seeds", default=None,
                   help="seeds: a range '0-14', a list '0,3,5' or one '7' (default: 0-4 for "
                   "the quick preset, the paper's 0-14 for paper and paper+)")
    p.add_argument("--episodes", type=int, default=None,
                   help="training episodes per seed (default: the preset's)")
    p.add_argument("--preset", "--variant", dest="preset", default=None,
                   help="quick (default: minutes), paper (the paper as written, its budget: "
                   "hours) or paper+ (the paper plus the changes of docs/paper-plus.md)")
    p.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE",
                   help="override a config field, e.g. agent.hidden=[64,64] (repeatable)")
    p.add_argument("--out", default="runs", help="parent directory of runs (default runs/)")
    p.add_argument("--name", default=None, help="run name, a directory made in OUT "
                   "(default ALGO-TASK-TIMESTAMP)")
    p.add_argument("--goal", action="append", default=[], metavar="INDEX:LOW:HIGH",
                   help="Gymnasium task: an observation entry HI-DDPG's goals fix, with its "
                   "bounds, e.g. --goal 8:-0.3:0.3 --goal 9:-0.3:0.3 (one per entry; needed "
                   "by hi-ddpg unless the environment declares a goal space)")
    p.add_argument("--skills", default=None, metavar="MODULE:FUNCTION",
                   help="Gymnasium task: h-DDPG's skills, a factory (env, config) -> "
                   "hiddpg.agents.skills.SkillPatterns (needed by h-ddpg unless the "
                   "environment declares them)")
    p.add_argument("--resume", default=None, metavar="DIR",
                   help="continue the run in DIR from its last checkpoint")
    return p


def _as_flag(err: ValueError, name: str) -> UsageError:
    """The library names a bad value by its parameter (``seeds '0,x': ...``); the command
    line names the flag that gave it (``--seeds '0,x': ...``)."""
    text = str(err)
    return UsageError(f"--{text}" if text.startswith(f"{name} ") else text)


#: the default seeds of each preset: a short look at several seeds, or the paper's 15 runs.
DEFAULT_SEEDS = {"quick": "0-4", "paper": "0-14", "paper+": "0-14"}
DEFAULT_PRESET = "quick"
#: what a run name may be: one directory inside ``--out``.
NAME_PATTERN = re.compile(r"[A-Za-z0-9][A-Za-z0-9._+=@-]*")


def check_name(name: str) -> str:
    """``--name`` is one plain directory name, so the run stays inside ``--out``."""
    if not NAME_PATTERN.fullmatch(name) or len(name) > 200:
        raise UsageError(f"--name {name!r}: a run name is one directory name of letters, "
                         "digits and . _ + = @ - (not starting with . or -); to put runs "
                         "elsewhere use --out DIR")
    return name


def _prepare(args: argparse.Namespace) -> tuple[Run, Trainer]:
    """Validate the command line, then create or open the run directory; nothing is written
    if a check fails and nothing is compiled."""
    from hiddpg.presets import make_config

    if args.resume:
        given = [n for n, v in (("ALGO", args.algo), ("TASK", args.task), ("--name", args.name),
                                ("--set", args.sets), ("--seeds", args.seeds),
                                ("--preset", args.preset), ("--goal", args.goal),
                                ("--skills", args.skills)) if v]
        if given:
            raise UsageError(f"--resume takes the run's config from {args.resume}; "
                             f"drop {', '.join(given)}")
        path = existing_dir(args.resume, "--resume")
        try:
            run, trainer, _ = open_for_resume(path, args.episodes)
        except RunFileError:
            raise
        except ValueError as err:
            raise _as_flag(err, "episodes") from None
        except FileNotFoundError as err:
            raise UsageError(f"--resume {args.resume!r}: {err}") from None
        return run, trainer
    if not args.algo or not args.task:
        raise UsageError("ALGO and TASK are required (or --resume DIR)")
    preset = args.preset or DEFAULT_PRESET
    try:
        seeds = parse_seeds(args.seeds or DEFAULT_SEEDS.get(preset, "0-4"))
    except ValueError as err:
        raise _as_flag(err, "seeds") from None
    out = output_dir(args.out, "--out")
    name = check_name(args.name) if args.name is not None else None
    sets = list(args.sets) + ([f"episodes={args.episodes}"] if args.episodes is not None else [])
    task = declare(args.task, args.goal, args.skills)  # a Gymnasium task's declaration
    config = make_config(args.algo, task, preset, sets)
    trainer = make_trainer(config)  # builds env and agent: validates env overrides
    gym = is_gym_task(config.task)
    path = out / (name or default_name(config.algo, directory_name(task) if gym else config.task))
    try:
        run = prepare_new(config, seeds, path)
    except FileExistsError as err:
        raise UsageError(f"{err}; choose another --name or --resume it") from None
    if gym:  # where the values came from, next to the declaration in config.json
        record_sources(run.path, config, trainer.env)
    return run, trainer


def main(argv: Sequence[str] | None = None,
         on_chunk: Callable[[Run, int], None] | None = None) -> int:
    """Run ``hiddpg train`` with ``argv``; returns the exit code. ``on_chunk(run, episodes)``
    is called after each chunk's checkpoint is written (tests use it to simulate a crash)."""
    argv = argv_or_help(argv, build_parser)
    if argv is None:
        return 0
    with declarations_scope():  # a Gymnasium declaration lasts as long as the command
        return _main(argv, on_chunk)


def _main(argv: list[str], on_chunk: Callable[[Run, int], None] | None) -> int:
    try:
        args = build_parser().parse_args(argv)
        run, trainer = _prepare(args)
    except (RunFileError, RunLockedError) as err:
        print(f"{PROG}: error: {err}", file=sys.stderr)
        return 1
    except (UsageError, ValueError, TypeError, FileNotFoundError) as err:
        print(f"{PROG}: error: {err}", file=sys.stderr)
        return 2
    if args.resume and _finished(run, trainer):
        print(f"{PROG}: {run.path} is finished ({run.config.episodes} episodes); nothing to "
              f"do. Train it longer with: hiddpg train --resume {run.path} --episodes N "
              f"(N > {run.config.episodes})", file=sys.stderr)
        run.close()
        print(_result_line(run, _last_wall(run)))
        return 0
    if is_gym_task(run.config.task):
        print(sources_line(value_sources(trainer.config, trainer.env)))
    reporter = ConsoleReporter()
    def stopped(sig: str) -> None:  # also before train_run has started
        mark_stopped(run, sig)
        print(f"{PROG}: stopped by {sig}; continue with: hiddpg train --resume {run.path}",
              file=sys.stderr)

    with on_stop(stopped):
        reporter.plan(describe(trainer.config, run.seeds, run.checkpoint_episodes()))
        result = train_run(run, trainer, on_chunk=on_chunk, reporter=reporter)
    if result.status == INTERRUPTED:
        print(f"{PROG}: interrupted; continue with: hiddpg train --resume {run.path}",
              file=sys.stderr)
        return 130
    if result.status == FAILED:
        print(f"{PROG}: error: {result.error}", file=sys.stderr)
        return 1
    print(_result_line(run, result.wall_time))
    return 0


def _result_line(run: Run, wall: float) -> str:
    """The line a run ends with (:func:`hiddpg.summary.result_line`); a Gymnasium task's has
    no baselines (they are jitted rollouts of our own tasks)."""
    if not is_gym_task(run.config.task):
        return result_line(run, wall)
    finals, env = final_evaluation(run)
    tail = f" | wall {wall:.1f} s | run {run.path}"
    if not finals:
        return "no evaluation recorded" + tail
    label = "environment return" if env else "return"
    return "final evaluation: " + score_text(finals, label) + tail


def _finished(run: Run, trainer: Trainer) -> bool:
    """The run has trained its budget and says so (nothing left to do on ``--resume``)."""
    try:
        status = run.progress().get("status")
    except RunFileError:
        return False
    return status == FINISHED and run.checkpoint_episodes() >= trainer.config.episodes


def _last_wall(run: Run) -> float:
    try:
        return float(run.progress()["wall_time"])
    except (RunFileError, KeyError, ValueError):
        return 0.0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

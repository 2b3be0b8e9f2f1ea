"""``hiddpg reproduce``: the paper's Figures 3-8, with the numbers behind them in report.md.

::

    hiddpg reproduce {fig3,fig4,fig5,fig6,fig7,fig8,all} [--scale quick|paper]
                     [--variant quick|paper|paper+|extended] [--seeds N]
                     [--out DIR] [--episodes N] [--set KEY=VALUE ...] [--part SEEDS]
                     [--algos ALGO,...]

Runs go to ``DIR/runs/<algo>-<task>/`` and are shared between figures; every run on disk is
reused (a finished one as is, an interrupted one resumed), so an invocation that is killed
continues where it stopped when run again. Figures go to ``DIR/figures/figN.png|pdf``, the
report to ``DIR/report.md`` (default ``DIR``: ``results/<scale>/<variant>``), each run's
artifact (what the figures read, small enough to commit) to ``DIR/artifacts/<algo>-<task>/``,
from which ``hiddpg report DIR`` redraws them without training. ``--scale quick``
takes minutes; ``--scale paper`` (15 seeds, the paper's budgets) takes hours. ``--variant``
says what is trained (default: ``quick`` at quick scale, ``paper`` at paper scale); every
figure and the report name it. ``all`` draws the puck figures before the arm's (cheap runs
first); ``--dry-run`` lists the runs it would train, resume or reuse and the environment steps
left. ``--part 0-4`` trains only those seeds of each run, as a run of their own whose artifact
(``DIR/parts/``, committed like the artifacts) is merged with the other parts into the run's
artifact (:mod:`hiddpg.experiments.parts`): a run too long to train in one go is trained part by
part, on any machine, and the figures are drawn from the seeds merged so far. ``--algos
hi-ddpg`` trains only that algorithm's runs, so a comparison figure's methods can be trained
one at a time; the figure draws the others from their artifacts where they exist, and
``all --algos`` passes over, with a note, a figure that trains none of them and lacks an
artifact (Fig. 6 under ``--algos ddpg`` before HI-DDPG's arm run exists).
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable, Sequence

from hiddpg.commands.common import Parser as _Parser
from hiddpg.commands.common import UsageError, report_error, run_command
from hiddpg.experiments.budgets import (
    DEFAULT_VARIANT,
    REPRODUCE_VARIANTS,
    SCALES,
    budget_table,
    variant_table,
)
from hiddpg.experiments.common import Context
from hiddpg.experiments.rundata import ExperimentError
from hiddpg.run_files import RunFileError, RunLockedError
from hiddpg.runner import parse_seeds
from hiddpg.stopping import on_stop

PROG = "hiddpg reproduce"
FIGURES = ("fig3", "fig4", "fig5", "fig6", "fig7", "fig8")


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog=PROG, formatter_class=argparse.RawDescriptionHelpFormatter,
                description="Reproduce the paper's figures; reuse or resume runs on disk.",
                epilog="budgets per scale:\n" + budget_table() + "\n\nvariants:\n"
                + variant_table())
    p.add_argument("figure", choices=(*FIGURES, "all"), help="which figure, or all")
    p.add_argument("--scale", choices=SCALES, default="quick",
                   help="quick (minutes, default) or paper (15 seeds, hours; resumable)")
    p.add_argument("--variant", choices=list(REPRODUCE_VARIANTS), default=None,
                   help="what to train: quick, paper (the paper as written), paper+ (the paper "
                        "plus docs/paper-plus.md's changes) or extended (default: quick at "
                        "quick scale, paper at paper scale)")
    p.add_argument("--seeds", type=int, default=None,
                   help="runs per method (seeds 0..N-1; default: the scale's)")
    p.add_argument("--part", default=None, metavar="SEEDS",
                   help="train only these seeds of each run (e.g. 0-4 or 5,6), as a run of "
                        "their own, and merge its artifact with the other parts in DIR/parts; "
                        "the figures show the seeds merged so far")
    p.add_argument("--algos", default=None, metavar="ALGO[,ALGO]",
                   help="train only these algorithms' runs (e.g. hi-ddpg,ddpg); a figure "
                        "draws every other method from its artifact, or leaves it out")
    p.add_argument("--out", default=None,
                   help="output directory (default results/<scale>/<variant>)")
    p.add_argument("--episodes", type=int, default=None,
                   help="training episodes of every run (default: the scale's budget)")
    p.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE",
                   help="config override for every run, as in `hiddpg train`; "
                        "agent.hidden=[..] sets every hidden-size field")
    p.add_argument("--dry-run", action="store_true",
                   help="list the runs this would train, resume or reuse, and the environment "
                        "steps left; train nothing")
    p.add_argument("--tasks", default=None, help=argparse.SUPPRESS)  # tests: Figs. 4-5 tasks
    return p


def runners() -> dict[str, Callable]:
    """Figure name -> the function that draws it (and trains or reuses its runs)."""
    from hiddpg.experiments import arm, comparison, trajectory

    return {"fig3": trajectory.fig3, "fig4": trajectory.fig4, "fig5": trajectory.fig5,
            "fig6": arm.fig6,
            "fig7": lambda ctx: comparison.run_comparison(ctx, "fig7"),
            "fig8": lambda ctx: comparison.run_comparison(ctx, "fig8")}


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``hiddpg reproduce`` with ``argv``; returns the exit code."""
    return run_command(PROG, argv, build_parser, _context, _reproduce)


def _context(args: argparse.Namespace) -> Context:
    """The experiment context of the command line, its config checked before any training."""
    if args.episodes is not None and args.episodes < 1:
        raise UsageError(f"--episodes {args.episodes} must be >= 1")
    tasks = tuple(t for t in (args.tasks or "").split(",") if t) or None
    variant = args.variant or DEFAULT_VARIANT[args.scale]
    try:
        part = tuple(parse_seeds(args.part)) if args.part is not None else None
    except ValueError as err:
        raise UsageError(f"--part: {err}") from None
    algos = None if args.algos is None else tuple(a.strip() for a in args.algos.split(","))
    ctx = Context(out=args.out or f"results/{args.scale}/{variant}", scale=args.scale,
                  variant=variant, seeds=args.seeds, episodes=args.episodes, sets=tuple(args.sets),
                  tasks=tasks, part=part, algos=algos)
    ctx.config("hi-ddpg", "PuckTrajectory1")  # a bad --set fails here, before training
    return ctx


def _reproduce(args: argparse.Namespace, ctx: Context) -> int:
    """Run the figures and write the report; 1 if an experiment fails, 130 if interrupted."""
    from hiddpg.experiments.redraw import write_context
    from hiddpg.experiments.report import write_report
    from hiddpg.experiments.schedule import CHEAP_FIRST, not_drawn, plan, plan_table
    from hiddpg.variants import same_as

    alias = same_as(ctx.variant)
    if alias is not None:
        print(f"{PROG}: variant {ctx.variant} adds no change to {alias} "
              f"(hiddpg.variants.PAPER_PLUS is empty, docs/diagnosis.md): its runs, figures "
              f"and numbers are {alias}'s; nothing to train here, run --variant {alias}")
        return 0
    figures = CHEAP_FIRST if args.figure == "all" else (args.figure,)
    if args.figure == "all":
        passed = {name: why for name in figures if (why := not_drawn(ctx, name))}
        for why in passed.values():
            print(f"{PROG}: {why}")
        figures = tuple(name for name in figures if name not in passed)
    if args.dry_run:
        try:
            table = plan_table(plan(ctx, figures))
        except (ExperimentError, RunFileError) as err:
            return report_error(PROG, err, code=1)
        print(f"{PROG}: {ctx.note()}, into {ctx.out}; nothing is trained (--dry-run)")
        print(table)
        return 0
    draw, t0 = runners(), time.perf_counter()
    stopped = on_stop(lambda sig: print(f"{PROG}: stopped by {sig}; run the same command "
                                        "again to continue", file=sys.stderr))
    try:
        write_context(ctx)
        with stopped:
            for name in figures:
                ctx.say(f"== {name}: {ctx.note()} ==")
                section = draw[name](ctx)
                ctx.say(f"{name}: {', '.join(section['figures'])} ({section['wall_s']:.1f} s)")
                write_report(ctx, time.perf_counter() - t0)
    except (ExperimentError, RunFileError, RunLockedError) as err:
        return report_error(PROG, err, code=1)
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted; run the same command again to continue", file=sys.stderr)
        return 130
    report = write_report(ctx, time.perf_counter() - t0)
    print(f"wrote {report} ({time.perf_counter() - t0:.1f} s)")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

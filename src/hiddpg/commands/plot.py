"""``hiddpg plot``: the Fig. 7/8 comparison (curves and t-test tiles) for any runs.

::

    hiddpg plot RUN_DIR [RUN_DIR ...] [--out FILE] [--metric COLUMN] [--stages N]

Each ``RUN_DIR`` is a run directory of ``hiddpg train`` or a directory holding such runs; one
that does not exist is named in the error, with the directories next to it whose names start
with it (run names end in a timestamp). Runs are labelled by their algorithm (with the directory
name when two share one). Writes ``FILE.png`` and ``FILE.pdf`` (default ``comparison``; a
``FILE`` ending in ``.png`` or ``.pdf`` names the same pair; missing parent directories are
created; neither may be an existing directory) and prints the final return per run and the
last-stage tests as markdown. The paths are checked before any run is read: a bad one prints
one line naming it and exits with code 2.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from typing import Any

from hiddpg.commands.common import Parser as _Parser
from hiddpg.commands.common import UsageError, run_command
from hiddpg.paths import existing_dir, figure_stem

PROG = "hiddpg plot"


def build_parser() -> argparse.ArgumentParser:
    from hiddpg.experiments.comparison import METRIC, N_STAGES

    p = _Parser(prog=PROG, description="Compare runs: mean ± std curves and Welch t-test "
                "tiles over training stages (the paper's Figs. 7-8).")
    p.add_argument("runs", nargs="+", metavar="RUN_DIR", help="run directories (or parents)")
    p.add_argument("--out", default="comparison", metavar="FILE",
                   help="output file without extension; FILE.png and FILE.pdf are written "
                   "(missing directories are created)")
    p.add_argument("--metric", default=METRIC,
                   help=f"metrics.csv column to compare (default {METRIC}; e.g. env_return)")
    p.add_argument("--stages", type=int, default=N_STAGES,
                   help=f"training stages of the tiles (default {N_STAGES})")
    p.add_argument("--title", default=None, help="figure title")
    return p


def _labels(runs: list) -> dict:
    counts: dict[str, int] = {}
    for r in runs:
        counts[r.label] = counts.get(r.label, 0) + 1
    out = {}
    for r in runs:
        label = r.label if counts[r.label] == 1 else f"{r.label} ({r.path.name})"
        out[label] = r
    return out


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``hiddpg plot`` with ``argv``; returns the exit code."""
    from hiddpg.experiments.rundata import ExperimentError

    return run_command(PROG, argv, build_parser, _compare, _plot,
                       errors=(UsageError, ValueError, ExperimentError, FileNotFoundError))


def _compare(args: argparse.Namespace) -> tuple[dict, Any]:
    """The labelled runs and their comparison; a usage error if there are none."""
    from hiddpg.experiments import comparison
    from hiddpg.experiments.rundata import discover_runs, load_run

    args.out = figure_stem(args.out, "--out")
    for run in args.runs:
        existing_dir(run, "RUN_DIR")
    if args.stages < 1:
        raise UsageError(f"--stages {args.stages} must be >= 1")
    paths = discover_runs(args.runs)
    if not paths:
        raise UsageError(f"no run directories under {args.runs}")
    runs = _labels([load_run(p) for p in paths])
    return runs, comparison.compare(runs, args.metric, args.stages)


def _plot(args: argparse.Namespace, compared: tuple[dict, Any]) -> int:
    """Write the figure and print the summary."""
    from hiddpg.experiments import comparison
    from hiddpg.experiments.report import save_figure

    runs, comp = compared
    tasks = sorted({r.config.task for r in runs.values()})
    title = args.title or f"{', '.join(tasks)}: {' vs '.join(runs)}"
    written = save_figure(comparison.plot_comparison(comp, title), args.out)
    print(comparison.summary_markdown(comparison.summary_numbers(comp)))
    print(f"wrote {', '.join(map(str, written))}")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

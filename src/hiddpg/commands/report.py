"""``hiddpg report`` and ``hiddpg claims``: what the outputs of ``hiddpg reproduce`` give,
read from their committed files, nothing trained.

::

    hiddpg report DIR [FIG ...]
    hiddpg claims [DIR ...] [--bars] [--figures] [--json] [--out FILE] [--update PAGE]

``report`` reads ``DIR/artifacts`` (written by ``hiddpg reproduce --out DIR``), never
``DIR/runs``: every figure whose artifacts are there (or the figures named) is drawn again
to ``DIR/figures``, its section to ``DIR/sections`` and ``DIR/report.md`` rewritten, with the
numbers ``hiddpg reproduce`` computed from the run directories.

``claims`` tables which of the paper's claims each output bears out (one row per claim, one
column per DIR; default: :data:`hiddpg.experiments.claims.DEFAULT_DIRS`) from its sections and
artifacts (:mod:`hiddpg.experiments.claims`); a DIR that does not exist is a column of
"not run yet".
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from hiddpg.commands.common import USAGE_ERRORS, UsageError, report_error, run_command
from hiddpg.commands.common import Parser as _Parser
from hiddpg.commands.reproduce import FIGURES, runners
from hiddpg.experiments.common import Context
from hiddpg.experiments.rundata import ExperimentError
from hiddpg.run_files import RunFileError

PROG = "hiddpg report"
CLAIMS_PROG = "hiddpg claims"


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog=PROG, description="Redraw the figures and report.md of an output "
                "directory of `hiddpg reproduce` from its artifacts, without training.")
    p.add_argument("dir", metavar="DIR", help="output directory of `hiddpg reproduce` "
                   "(e.g. results/paper/paper), holding artifacts/")
    p.add_argument("figures", nargs="*", metavar="FIG",
                   help=f"figures to draw ({', '.join(FIGURES)}; default: every figure whose "
                        "artifacts are there)")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``hiddpg report`` with ``argv``; returns the exit code."""
    return run_command(PROG, argv, build_parser, _prepare, _redraw,
                       errors=(*USAGE_ERRORS, ExperimentError))


def _prepare(args: argparse.Namespace) -> tuple[Context, list[str], dict[str, str | None]]:
    """The context of ``args.dir``'s artifacts and the figures to draw; a missing directory,
    artifact or asked-for figure's artifact is a usage error."""
    from hiddpg.experiments.redraw import artifact_context, drawable

    unknown = [f for f in args.figures if f not in FIGURES]
    if unknown:
        raise UsageError(f"figure {unknown[0]!r} is not one of {', '.join(FIGURES)}")
    ctx = artifact_context(args.dir)
    why = drawable(ctx)
    for name in args.figures:
        if why[name]:
            raise UsageError(f"{name} cannot be drawn: {why[name]}")
    figures = list(dict.fromkeys(args.figures)) or [f for f in FIGURES if not why[f]]
    if not figures:
        raise UsageError(f"no figure has its artifacts under {ctx.out / 'artifacts'}")
    return ctx, figures, why


def _redraw(args: argparse.Namespace, prepared) -> int:
    """Draw the figures, rewrite the report; 1 if an artifact cannot be read."""
    from hiddpg.experiments.report import write_report

    ctx, figures, why = prepared
    draw, t0 = runners(), time.perf_counter()
    try:
        for name in FIGURES:
            if name not in figures:
                if why[name] and not args.figures:
                    print(f"{name}: skipped ({why[name]})")
                continue
            section = draw[name](ctx)
            print(f"{name}: {', '.join(section['figures'])} ({section['wall_s']:.1f} s)")
        report = write_report(ctx, time.perf_counter() - t0)
    except (ExperimentError, RunFileError) as err:
        return report_error(PROG, err, code=1)
    print(f"wrote {report} ({time.perf_counter() - t0:.1f} s)")
    return 0


# ---------------------------------------------------------------------------- hiddpg claims


def build_claims_parser() -> argparse.ArgumentParser:
    from hiddpg.experiments.claims import DEFAULT_DIRS

    p = _Parser(prog=CLAIMS_PROG, description="Which of the paper's claims each output of "
                "`hiddpg reproduce` bears out, from its sections and artifacts (no training).")
    p.add_argument("dirs", nargs="*", metavar="DIR", default=list(DEFAULT_DIRS),
                   help=f"output directories of `hiddpg reproduce` (default: "
                        f"{' '.join(DEFAULT_DIRS)})")
    p.add_argument("--bars", action="store_true",
                   help="also print the claims: the paper's words and the bar of each")
    p.add_argument("--figures", action="store_true",
                   help="also print, per figure, each output's figure and the numbers behind "
                        "it (docs/results.md's figure sections)")
    p.add_argument("--json", action="store_true",
                   help="print the verdicts, numbers and seeds as JSON instead")
    p.add_argument("--out", default=None, metavar="FILE", help="also write the output to FILE")
    p.add_argument("--update", default=None, metavar="PAGE",
                   help="rewrite the generated blocks of the markdown page PAGE (between "
                        "'<!-- hiddpg claims: NAME -->' and '<!-- end -->'; NAME: verdicts, "
                        "bars, summary, fig3 ... fig8), e.g. docs/results.md or README.md")
    return p


def claims(argv: Sequence[str] | None = None) -> int:
    """Run ``hiddpg claims`` with ``argv``; returns the exit code."""
    return run_command(CLAIMS_PROG, argv, build_claims_parser, _assess, _print_claims,
                       errors=(*USAGE_ERRORS, ExperimentError))


def _assess(args: argparse.Namespace):
    from hiddpg.experiments.claims import assess
    from hiddpg.variants import same_as

    assessment = assess(args.dirs)
    missing = set()
    for d, read in zip(args.dirs, assessment.paths, strict=True):
        if not Path(read).is_dir() and read not in missing:
            missing.add(read)
            print(f"{CLAIMS_PROG}: {read} does not exist: every claim is not run yet there",
                  file=sys.stderr)
        if Path(read) != Path(d):
            print(f"{CLAIMS_PROG}: {d}: variant {Path(d).name} adds no change to "
                  f"{same_as(Path(d).name)}: read from {read}", file=sys.stderr)
    return assessment


def _print_claims(args: argparse.Namespace, assessment) -> int:
    from hiddpg.experiments.claims import (
        definitions_markdown,
        figure_markdown,
        markdown,
        update_page,
    )

    if args.json:
        text = json.dumps(assessment.to_json(), indent=2)
    else:
        text = markdown(assessment) + ("\n\n" + definitions_markdown() if args.bars else "")
        if args.figures:
            text += "".join(f"\n\n## {name}\n\n{figure_markdown(assessment, name)}"
                            for name in FIGURES)
    print(text)
    if args.out:
        Path(args.out).write_text(text + "\n")
    if args.update:
        page = Path(args.update)
        try:
            before = page.read_text(encoding="utf-8")
            after = update_page(before, assessment)
        except (OSError, ValueError) as err:
            return report_error(CLAIMS_PROG, UsageError(f"--update {page}: {err}"), code=2)
        page.write_text(after, encoding="utf-8")
        print(f"{CLAIMS_PROG}: {page}: "
              f"{'updated' if after != before else 'already up to date'}", file=sys.stderr)
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

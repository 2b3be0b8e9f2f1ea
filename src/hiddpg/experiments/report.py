"""report.md: the numbers behind the figures, rebuilt from every figure's stored section.

Each figure writes ``sections/figN.json`` (title, figure paths, a markdown body, the numbers
as JSON, its wall-clock time); :func:`write_report` joins the sections present, in figure
order, under a header with the budgets and the time spent, so figures made by separate
invocations end up in one report. Numbers are printed plainly (``-12.3 ± 4.5``,
``-12.0 [-15.1, -9.8]``) so that they parse back (:func:`parse_numbers`).
"""

from __future__ import annotations

import json
import math
import re
import time
from pathlib import Path
from typing import Any

import numpy as np

from hiddpg.experiments.artifacts import META_FILE
from hiddpg.experiments.budgets import BUDGETS, budget_table, variant_table
from hiddpg.experiments.common import Context
from hiddpg.experiments.schedule import left, left_table
from hiddpg.runs import PROGRESS_FILE, atomic_write

ORDER = ("fig3", "fig4", "fig5", "fig6", "fig7", "fig8")
REPORT_FILE = "report.md"
_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*(?:e[-+]?\d+)?|inf)|nan", re.IGNORECASE)


def fmt(x: float | None, digits: int = 3) -> str:
    """``x`` with ``digits`` significant digits, in fixed notation from 1 up (``-833``,
    ``12.3``, ``0.00565``); ``nan`` for a missing value."""
    if x is None or not math.isfinite(float(x)):
        return "nan" if x is None or math.isnan(float(x)) else str(float(x))
    x = float(x)
    if abs(x) >= 1:
        return f"{x:.{max(0, digits - 1 - int(math.floor(math.log10(abs(x)))))}f}"
    return f"{x:.{digits}g}"


def fmt_pm(mean: float, std: float) -> str:
    return f"{fmt(mean)} ± {fmt(std, 2)}"


def fmt_ci(estimate: float, low: float, high: float) -> str:
    return f"{fmt(estimate)} [{fmt(low)}, {fmt(high)}]"


def parse_numbers(text: str) -> list[float]:
    """Every number in ``text`` (a table cell or a line), in order."""
    return [float(m) for m in _NUMBER.findall(text)]


def table_rows(markdown: str) -> list[list[str]]:
    """The body rows of every markdown table in ``markdown`` (header and rule skipped)."""
    rows, previous = [], ""
    for line in markdown.splitlines():
        if line.startswith("|") and not set(line) <= set("|-: "):
            if not previous.startswith("|"):
                previous = line  # a header
                continue
            rows.append([c.strip() for c in line.strip().strip("|").split("|")])
        previous = line
    return rows


def load_sections(out: Path) -> dict[str, dict]:
    sections = {}
    for name in ORDER:
        path = out / "sections" / f"{name}.json"
        if path.is_file():
            sections[name] = json.loads(path.read_text())
    return sections


def training_wall_time(out: Path, from_artifacts: bool = False) -> dict[str, float]:
    """Wall-clock training seconds of every run: each artifact under ``out/artifacts`` (a run
    merged from parts: the sum of its parts), and, unless ``from_artifacts``, every run
    directory under ``out/runs`` that no artifact records yet (a run or part in progress)."""
    times, recorded = {}, set()
    for path in sorted((out / "artifacts").glob(f"*/{META_FILE}")):
        meta, name = json.loads(path.read_text()), path.parent.name
        recorded |= {name} | {f"{name}.{p['part']}" for p in meta.get("parts") or []}
        if meta.get("wall_time") is not None:
            times[name] = float(meta["wall_time"])
    if not from_artifacts:
        for path in sorted((out / "runs").glob(f"*/{PROGRESS_FILE}")):
            wall = json.loads(path.read_text()).get("wall_time")
            if path.parent.name not in recorded and wall is not None:
                times[f"{path.parent.name} (no artifact yet)"] = float(wall)
    return times


def runs_table(out: Path) -> list[str]:
    """Markdown lines: every artifact under ``out/artifacts`` with the seeds it holds, its
    episodes and status, and the parts it was merged from (:mod:`.parts`)."""
    from hiddpg.runner import seed_ranges

    lines = ["| run | seeds | episodes | status | trained in |", "|---|---|---:|---|---|"]
    for path in sorted((out / "artifacts").glob(f"*/{META_FILE}")):
        meta = json.loads(path.read_text())
        parts = meta.get("parts")
        made = (", ".join(p["part"] for p in parts) if parts else "one run")
        lines.append(f"| {path.parent.name} | {', '.join(seed_ranges(meta['seeds']))} | "
                     f"{meta.get('episodes')} | {meta.get('status')} | {made} |")
    return lines


def machines_table(out: Path) -> list[str]:
    """Markdown lines: for every artifact under ``out/artifacts`` (each part of a merged one),
    which machine trained which episodes in how many wall-clock seconds
    (:mod:`hiddpg.machine`; "not recorded" for episodes trained before machines were)."""
    from hiddpg.machine import machine_text
    from hiddpg.runner import seed_ranges

    lines = ["| run | seeds | episodes | machine | wall-clock seconds |",
             "|---|---|---|---|---:|"]
    for path in sorted((out / "artifacts").glob(f"*/{META_FILE}")):
        meta = json.loads(path.read_text())
        for rec in sorted(meta.get("parts") or [meta], key=lambda r: min(r["seeds"])):
            spans = rec.get("machines") or [{"machine": None, "wall_time": rec.get("wall_time"),
                                             "episodes": [0, rec.get("episodes")]}]
            seeds = ", ".join(seed_ranges(rec["seeds"]))
            for span in spans:
                first, last = span["episodes"]
                lines.append(f"| {path.parent.name} | {seeds} | {first + 1}-{last} | "
                             f"{machine_text(span['machine'])} | {span['wall_time']} |")
    return lines


MACHINES_NOTE = ("Per run (each part of a run merged from parts): which machine trained which "
                 "episodes, and in how many wall-clock seconds. Speed differs between CPUs "
                 "(compare times only on one machine), and a seed trained on CPUs with other "
                 "vector extensions may differ from itself in its last bits.")


LEFT_NOTE = ("What every figure still needs: per run, the seeds its artifact holds finished, the "
             "environment steps the others take (seeds x episodes x horizon: an upper bound where "
             "episodes end early) and the hours they would take at this output's measured rate "
             "(the run's own finished seeds; else the same algorithm's finished runs on other "
             "tasks, whose horizons and networks may differ; else all finished runs; on this "
             "output's machine). h-DDPG updates its four skills at every step, so its steps cost "
             "several times DDPG's (docs/performance.md): the rate of other algorithms "
             "underestimates its hours.")


def write_report(ctx: Context, invocation_s: float | None = None) -> Path:
    """Rebuild ``report.md`` from the stored sections."""
    sections = load_sections(ctx.out)
    train = training_wall_time(ctx.out, ctx.from_artifacts)
    writer = ("Redrawn by `hiddpg report` from the artifacts (nothing trained)"
              if ctx.from_artifacts else "Written by `hiddpg reproduce`")
    scale_budgets = {f: b for (s, f), b in BUDGETS.items() if s == ctx.scale}
    seeds = ctx.seeds or max(b.seeds for b in scale_budgets.values())
    lines = [f"# HI-DDPG reproduction: variant {ctx.variant}, {ctx.scale} scale", "",
             f"Variant {ctx.describe()}.", "",
             f"{writer} on {time.strftime('%Y-%m-%d %H:%M:%S')}; "
             f"{seeds} seeds per method (seeds 0-{seeds - 1}); the run (seed) is the unit of "
             "every statistic; the seeds each run holds so far are in the table of runs.", "",
             "## Budgets", "", budget_table(), "", "## Variants", "", variant_table(), "",
             "## Runs", "", *runs_table(ctx.out), "",
             "## Where the runs trained", "", MACHINES_NOTE, "", *machines_table(ctx.out), "",
             "## Still to train", "", LEFT_NOTE, "", left_table(left(ctx)), ""]
    if ctx.episodes or ctx.sets or ctx.seeds:
        lines += [f"Overrides of this output: seeds={ctx.seeds}, episodes={ctx.episodes}, "
                  f"set={list(ctx.sets)}.", ""]
    lines += ["## Time spent", "", "| item | wall-clock seconds |", "|---|---:|"]
    lines += [f"| {name}: training or reuse, evaluation, figure (when last made) | "
              f"{s['wall_s']:.1f} |" for name, s in sections.items()]
    lines += [f"| training {name} (all invocations) | {t:.1f} |" for name, t in train.items()]
    lines.append(f"| training, total (all invocations) | {sum(train.values()):.1f} |")
    if invocation_s is not None:
        lines.append(f"| this invocation | {invocation_s:.1f} |")
    lines.append("")
    for name, s in sections.items():
        lines += [f"## {s['title']}", ""]
        lines += [f"![{name}]({p})" for p in s["figures"] if p.endswith(".png")]
        lines += ["", s["markdown"], ""]
    path = ctx.out / REPORT_FILE
    ctx.out.mkdir(parents=True, exist_ok=True)
    atomic_write(path, "\n".join(lines).encode())
    return path


# ------------------------------------------------------------------------ figures, sections


def pyplot() -> Any:
    """``matplotlib.pyplot`` on the Agg backend (no display needed)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig: Any, stem: Path, note: str | None = None) -> list[Path]:
    """Write ``fig`` as ``stem.png`` and ``stem.pdf`` (the suffixes appended to the whole name,
    so ``a.v2`` gives ``a.v2.png``), with ``note`` (what the figure shows: the variant) as a
    line at its foot; close it; return the two paths."""
    plt = pyplot()
    if note:
        fig.text(0.01, 0.0, note, fontsize=7, ha="left", va="top", wrap=True)
    stem.parent.mkdir(parents=True, exist_ok=True)
    paths = [stem.with_name(stem.name + ".png"), stem.with_name(stem.name + ".pdf")]
    for p in paths:
        fig.savefig(p, dpi=150, bbox_inches="tight")
    plt.close(fig)
    return paths


def write_section(ctx: Context, name: str, section: dict[str, Any]) -> Path:
    """Store a figure's report section (``title``, ``figures``, ``markdown``, ``numbers``,
    ``wall_s``) as ``sections/<name>.json``, with the variant and scale it shows."""
    section = {**section, "variant": ctx.variant, "scale": ctx.scale}
    path = ctx.out / "sections" / f"{name}.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(path, (json.dumps(section, indent=2, default=_json_default) + "\n").encode())
    return path


def _json_default(obj: Any) -> Any:
    if isinstance(obj, np.generic | np.ndarray):
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"cannot serialise {type(obj).__name__}")

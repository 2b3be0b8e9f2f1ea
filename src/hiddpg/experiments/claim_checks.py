"""How each of the paper's claims is checked on one output of ``hiddpg reproduce``.

A check reads what the figures' sections (``OUT/sections/figN.json``) and the runs' artifacts
(``OUT/artifacts/``) hold, never run directories, and returns an :class:`Outcome`: the verdict,
the numbers with their intervals and the seeds. A claim the paper makes about several tasks
needs each of them: a task that fails decides "not reproduced", a task without its figure
leaves the claim "not run". The claims themselves, with the bars these checks apply, are in
:mod:`hiddpg.experiments.claims`.

"Most runs" is at least 80% of the runs (12 of 15, the paper's count per method); "most
stages" is more than half of them. Significance is Welch's t-test on the stage means of
Figs. 7-8 with Holm's correction over all pairs and stages, as the figures mark it
(:mod:`hiddpg.experiments.comparison`).
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from scipy import stats as sps

from hiddpg.experiments.artifacts import ARTIFACTS_DIR, load_artifact, read_meta
from hiddpg.experiments.budgets import BUDGETS, SCALES
from hiddpg.experiments.comparison import ALPHA, compare
from hiddpg.experiments.comparison import FIGURES as COMPARED_TASK
from hiddpg.experiments.redraw import CONTEXT_FILE
from hiddpg.experiments.report import fmt_ci, fmt_pm, load_sections
from hiddpg.experiments.rundata import LABELS, ExperimentError
from hiddpg.experiments.trajectory import TASKS as TRAJECTORY
from hiddpg.runner import seed_ranges

REPRODUCED, NOT_REPRODUCED, NOT_RUN = "reproduced", "not reproduced", "not run"
MOST_RUNS = 0.8
"""A fraction of runs at or above this is "most runs" (12 of 15)."""
RMS_LIMIT = 0.2
"""The low level's actions fit iLQR's when their RMS difference is at most this: a tenth of the
action range [-1, 1]."""
SHORT = {"PuckTrajectory1": "PT1", "PuckTrajectory2": "PT2", "PuckTrajectory3": "PT3",
         "PuckObstacle": "puck", "ArmObstacle": "arm"}


@dataclass
class Outcome:
    """One claim on one output: the verdict, what was measured (short text and numbers) and
    the seeds of the runs it comes from."""

    verdict: str
    text: str = ""
    numbers: dict[str, Any] = field(default_factory=dict)
    seeds: list[int] = field(default_factory=list)
    """Every seed of the runs the claim reads."""
    fewest: int | None = None
    """The fewest seeds one of those runs holds (``None``: ``len(seeds)``)."""
    planned: int | None = None
    """The runs per method the output is meant to hold (seeds 0..planned-1); runs with fewer
    seeds (trained part by part, not yet whole) are named in the cell."""

    def cell(self) -> str:
        """The markdown table cell: verdict, numbers, seeds (of the planned ones, if fewer)."""
        if self.verdict == NOT_RUN and not self.text:
            return "not run yet"
        head = f"**{self.verdict}**" if self.verdict != NOT_RUN else "not run yet"
        seeds = f"; seeds {seed_text(self.seeds)}" if self.seeds else ""
        fewest = len(self.seeds) if self.fewest is None else self.fewest
        if self.seeds and fewest < len(self.seeds):
            seeds += f", some runs on {fewest} of them so far"
        elif self.seeds and self.planned and len(self.seeds) < self.planned:
            seeds += f" of 0-{self.planned - 1} so far"
        return f"{head}: {self.text}{seeds}"


class Output:
    """One output directory of ``hiddpg reproduce`` (``results/<scale>/<variant>``) as the
    claims read it: its figure sections and its artifacts."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self.sections = load_sections(self.path) if self.path.is_dir() else {}
        self.label = _label(self.path, self.sections)
        self.planned = _planned(self.path)
        self._comparisons: dict[str, tuple[Any, list[int]]] = {}

    def seeds(self, algo: str, tasks: Sequence[str]) -> dict[str, Any]:
        """``seeds``: every seed of ``algo``'s artifacts on ``tasks`` (those present);
        ``fewest``: the fewest one of them holds (:class:`Outcome`'s fields)."""
        found: list[set[int]] = []
        for task in tasks:
            try:
                found.append(set(read_meta(self.path / ARTIFACTS_DIR / f"{algo}-{task}")
                                 ["seeds"]))
            except ExperimentError:
                continue
        return {"seeds": sorted(set().union(*found)),
                "fewest": min(map(len, found)) if found else None}

    def comparison(self, name: str) -> Any:
        """Fig. 7's or 8's :class:`~hiddpg.experiments.comparison.Comparison` recomputed from
        the artifacts of the methods its section shows; ``None`` without the section."""
        if name not in self._comparisons:
            self._comparisons[name] = self._compare(name)
        return self._comparisons[name][0]

    def comparison_seeds(self, name: str) -> dict[str, Any]:
        """``seeds`` and ``fewest`` (as :meth:`seeds`) of the runs in Fig. ``name``'s
        comparison."""
        self.comparison(name)
        return self._comparisons[name][1]

    def _compare(self, name: str) -> tuple[Any, list[int]]:
        section = self.sections.get(name)
        if section is None:
            return None, {"seeds": []}
        algo = {label: a for a, label in LABELS.items()}
        runs = {m: load_artifact(self.path / ARTIFACTS_DIR / f"{algo[m]}-{COMPARED_TASK[name]}")
                for m in section["numbers"]["final"]}
        seeds = {"seeds": sorted({int(s) for run in runs.values() for s in run.seeds}),
                 "fewest": min(len(run.seeds) for run in runs.values())}
        return compare(runs), seeds


def _label(path: Path, sections: dict[str, dict]) -> str:
    """``variant (scale scale)`` as recorded by the output, else as its path names it."""
    recorded = path / ARTIFACTS_DIR / CONTEXT_FILE
    if recorded.is_file():
        data = json.loads(recorded.read_text())
        return f"{data['variant']} ({data['scale']} scale)"
    for section in sections.values():
        return f"{section['variant']} ({section['scale']} scale)"
    if len(path.parts) >= 2 and path.parts[-2] in SCALES:
        return f"{path.parts[-1]} ({path.parts[-2]} scale)"
    return str(path)


def _planned(path: Path) -> int | None:
    """The runs per method the output asked for (``--seeds``), else its scale's budget's."""
    recorded = path / ARTIFACTS_DIR / CONTEXT_FILE
    if not recorded.is_file():
        return None
    data = json.loads(recorded.read_text())
    return data.get("seeds") or max((b.seeds for (s, _), b in BUDGETS.items()
                                     if s == data.get("scale")), default=None)


# ------------------------------------------------------------------------------ helpers


def seed_text(seeds: Sequence[int]) -> str:
    """``0-14``, ``0-2, 5``: the seeds as runs of consecutive numbers."""
    return ", ".join(seed_ranges(seeds))


def proportion_ci(k: int, n: int) -> tuple[float, float]:
    """The exact (Clopper-Pearson) 95% interval of a proportion ``k / n``."""
    ci = sps.binomtest(k, n).proportion_ci(confidence_level=0.95, method="exact")
    return float(ci.low), float(ci.high)


def count_text(k: int, n: int) -> str:
    """``12/15 (52-96%)``: a count with its exact 95% interval."""
    low, high = proportion_ci(k, n)
    return f"{k}/{n} ({100 * low:.0f}-{100 * high:.0f}%)"


def most_runs(k: int, n: int) -> bool:
    return n > 0 and k >= MOST_RUNS * n - 1e-9


def most_of(k: int, n: int) -> bool:
    return 2 * k > n


def _decide(passed: dict[str, bool], wanted: Sequence[str]) -> str:
    """Failing one task decides; a task not measured leaves the claim not run."""
    if not all(passed.values()):
        return NOT_REPRODUCED
    return REPRODUCED if all(t in passed for t in wanted) else NOT_RUN


def _missing(passed: dict[str, bool], wanted: Sequence[str]) -> str:
    gone = [SHORT[t] for t in wanted if t not in passed]
    return f"; {', '.join(gone)} not run" if gone else ""


def _iqm(summary: dict) -> str:
    return fmt_ci(summary["iqm"], summary["ci_low"], summary["ci_high"])


# ------------------------------------------------------------------------------ measures


def _trajectory_counts(part: str) -> Callable[[Output], Outcome]:
    """Claims 1-2: per trajectory task, the runs meeting one part of Fig. 4's bar."""

    def measure(out: Output) -> Outcome:
        section = out.sections.get("fig4")
        if section is None:
            return Outcome(NOT_RUN)
        measured = {t: section["numbers"][t]["bar"] for t in TRAJECTORY
                    if t in section["numbers"]}
        passed = {t: most_runs(b[part], b["runs"]) for t, b in measured.items()}
        numbers = {t: {"met": b[part], "runs": b["runs"],
                       "ci95": proportion_ci(b[part], b["runs"])} for t, b in measured.items()}
        text = ", ".join(f"{SHORT[t]} {count_text(b[part], b['runs'])}"
                         for t, b in measured.items())
        return Outcome(_decide(passed, TRAJECTORY), text + _missing(passed, TRAJECTORY),
                       numbers, **out.seeds("hi-ddpg", list(measured)))

    return measure


def _fits_ilqr(out: Output) -> Outcome:
    """Claim 3: Fig. 5's RMS difference of the drawn run's actions and iLQR's."""
    section = out.sections.get("fig5")
    if section is None:
        return Outcome(NOT_RUN)
    measured = {t: section["numbers"][t] for t in TRAJECTORY if t in section["numbers"]}
    passed = {t: bool(n["ilqr_converged"]) and max(n["rms_x"], n["rms_y"]) <= RMS_LIMIT
              for t, n in measured.items()}
    text = "RMS x/y, median run: " + ", ".join(
        f"{SHORT[t]} {n['rms_x']:.2f}/{n['rms_y']:.2f} (seed {n['drawn_seed']}"
        + ("" if n["ilqr_converged"] else ", iLQR not converged") + ")"
        for t, n in measured.items())
    numbers = {t: {k: n[k] for k in ("rms_x", "rms_y", "ilqr_converged", "drawn_seed")}
               for t, n in measured.items()}
    return Outcome(_decide(passed, TRAJECTORY), text + _missing(passed, TRAJECTORY), numbers,
                   **out.seeds("hi-ddpg", list(measured)))


def _avoids_obstacle(out: Output) -> Outcome:
    """Claim 4: Fig. 6B's successes (hand at the target, no collision) over runs."""
    section = out.sections.get("fig6")
    if section is None:
        return Outcome(NOT_RUN)
    n = section["numbers"]
    runs, ok, hit = len(n["success"]), int(sum(n["success"])), int(sum(n["collision"]))
    sw, ret = np.asarray(n["switches"], float), n["final_eval_return"]
    text = (f"success {count_text(ok, runs)}, collisions {hit}/{runs}, return IQM {_iqm(ret)}, "
            f"switches {fmt_pm(sw.mean(), sw.std(ddof=1) if runs > 1 else float('nan'))}")
    numbers = {"success": ok, "runs": runs, "ci95": proportion_ci(ok, runs), "collisions": hit,
               "final_eval_return": ret, "switches": sw.tolist()}
    verdict = REPRODUCED if most_runs(ok, runs) else NOT_REPRODUCED
    return Outcome(verdict, text, numbers, **out.seeds("hi-ddpg", ["ArmObstacle"]))


def stage_wins(comp: Any, a: str, b: str, late: bool) -> tuple[int, int, int]:
    """Stages where ``a`` beats ``b`` and where ``b`` beats ``a`` (Holm p < ALPHA), and the
    stages counted: all, or the second half of training (``late``)."""
    w = comp.welch
    i, j = w.methods.index(a), w.methods.index(b)
    stages = range(w.t.shape[2] // 2 if late else 0, w.t.shape[2])
    sig = [s for s in stages if w.p_holm[i, j, s] < ALPHA]
    return (int(sum(w.t[i, j, s] > 0 for s in sig)), int(sum(w.t[i, j, s] < 0 for s in sig)),
            len(stages))


def _late(comp: Any) -> str:
    first = comp.bounds[len(comp.bounds) // 2][0]
    return f"episodes {first}-{comp.bounds[-1][1]}"


def _compared(out: Output, name: str, methods: Sequence[str]) -> tuple[Any, str | None]:
    """Fig. ``name``'s comparison, or why it cannot decide (methods missing, too few runs)."""
    comp = out.comparison(name)
    if comp is None:
        return None, None
    gone = [m for m in methods if m not in comp.methods]
    if gone:
        return None, f"{', '.join(gone)} not run on {COMPARED_TASK[name]}"
    if comp.welch is None:
        return None, "too few runs for a t-test"
    return comp, None


def _final(out: Output, name: str, methods: Sequence[str]) -> str:
    final = out.sections[name]["numbers"]["final"]
    return ", ".join(f"{m} {_iqm(final[m])}" for m in methods)


def _puck_similar(out: Output) -> Outcome:
    """Claim 5: HI-DDPG ~ h-DDPG and HI-DDPG > DDPG on PuckObstacle, late in training."""
    hi, h, flat = LABELS["hi-ddpg"], LABELS["h-ddpg"], LABELS["ddpg"]
    comp, why = _compared(out, "fig7", (hi, h, flat))
    if comp is None:
        return Outcome(NOT_RUN, why or "")
    up, down, n = stage_wins(comp, hi, h, late=True)
    beat, _, _ = stage_wins(comp, hi, flat, late=True)
    verdict = REPRODUCED if not most_of(up + down, n) and most_of(beat, n) else NOT_REPRODUCED
    text = (f"{_late(comp)}: {hi} vs {h} differ in {up + down}/{n} stages, {hi} > {flat} in "
            f"{beat}/{n}; last-stage IQM {_final(out, 'fig7', (hi, h, flat))}")
    numbers = {"stages": n, "hi_vs_h_differ": up + down, "hi_beats_ddpg": beat,
               "final": out.sections["fig7"]["numbers"]["final"]}
    return Outcome(verdict, text, numbers, **out.comparison_seeds("fig7"))


def _arm_beats_h(out: Output) -> Outcome:
    """Claim 6: HI-DDPG > h-DDPG on ArmObstacle in most late stages."""
    hi, h = LABELS["hi-ddpg"], LABELS["h-ddpg"]
    comp, why = _compared(out, "fig8", (hi, h))
    if comp is None:
        return Outcome(NOT_RUN, why or "")
    up, _, n = stage_wins(comp, hi, h, late=True)
    everywhere, _, total = stage_wins(comp, hi, h, late=False)
    text = (f"{_late(comp)}: {hi} > {h} in {up}/{n} stages ({everywhere}/{total} overall); "
            f"last-stage IQM {_final(out, 'fig8', (hi, h))}")
    numbers = {"stages": n, "hi_beats_h": up, "hi_beats_h_overall": everywhere,
               "final": out.sections["fig8"]["numbers"]["final"]}
    return Outcome(REPRODUCED if most_of(up, n) else NOT_REPRODUCED, text, numbers,
                   **out.comparison_seeds("fig8"))


def _model_helps(out: Output) -> Outcome:
    """Claim 7: HI-DDPG > HI-DDPG-wo-model in most stages, on both obstacle tasks."""
    hi, wo = LABELS["hi-ddpg"], LABELS["hi-ddpg-wo-model"]
    passed, parts, numbers, seeds, fewest, why = {}, [], {}, set(), [], []
    for name, task in COMPARED_TASK.items():
        comp, reason = _compared(out, name, (hi, wo))
        if comp is None:
            why += [reason] if reason else []
            continue
        up, _, n = stage_wins(comp, hi, wo, late=False)
        passed[task] = most_of(up, n)
        final = out.sections[name]["numbers"]["final"]
        parts.append(f"{SHORT[task]} {up}/{n} (IQM {_iqm(final[hi])} vs {_iqm(final[wo])})")
        numbers[task] = {"stages": n, "hi_beats_wo_model": up, "final": final}
        seeds |= set(out.comparison_seeds(name)["seeds"])
        fewest.append(out.comparison_seeds(name)["fewest"])
    wanted = tuple(COMPARED_TASK.values())
    if not passed:
        return Outcome(NOT_RUN, "; ".join(why))
    text = (f"stages with {hi} > {wo}: " + ", ".join(parts) + _missing(passed, wanted))
    return Outcome(_decide(passed, wanted), text, numbers, sorted(seeds), min(fewest))


#: Claim number -> its check (:data:`hiddpg.experiments.claims.CLAIMS` states each bar).
CHECKS: dict[int, Callable[[Output], Outcome]] = {
    1: _trajectory_counts("goals"), 2: _trajectory_counts("switches"), 3: _fits_ilqr,
    4: _avoids_obstacle, 5: _puck_similar, 6: _arm_beats_h, 7: _model_helps}

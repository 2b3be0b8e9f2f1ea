"""Figs. 7-8: HI-DDPG, h-DDPG, HI-DDPG-wo-model and DDPG compared over training.

Top: mean ± std over runs of the episode return. Bottom: the paper's tiles, Welch's t-test
between every pair of methods at every training stage, coloured ``-log10(p) * sign(t)``
(:func:`hiddpg.experiments.stats.pairwise_welch`), the p-value printed in each tile and ``*``
where it survives Holm's correction over all pairs and stages. A stage is a contiguous block of
evaluation points; a run's score at a stage is its mean over the block (the run is the unit).

The default score is the noise-free evaluation episode's environment return
(``eval_env_return``): it measures the learned policy, with no exploration noise, and is the
same quantity for every method (HI-DDPG's high-level return adds its switch cost).
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from hiddpg.experiments import stats
from hiddpg.experiments.common import Context, available, ensure_run
from hiddpg.experiments.report import fmt, fmt_ci, fmt_pm, pyplot, save_figure, write_section
from hiddpg.experiments.rundata import RunData, load_run
from hiddpg.presets import task_family
from hiddpg.runner import seed_ranges

COMPARED = ("hi-ddpg", "h-ddpg", "hi-ddpg-wo-model", "ddpg")
"""The paper's four methods, in its order."""
METRIC = "eval_env_return"
FALLBACK_METRICS = ("eval_return", "env_return")
N_STAGES = 10
"""Training stages of the tiles (columns)."""
ALPHA = 0.05
"""Significance level of the ``*`` marks (Holm-adjusted p-values)."""
COLOUR_LIMIT = 4.0
"""The tile colour scale saturates at ``|-log10 p| = 4`` (p = 1e-4)."""
FIGURES = {"fig7": "PuckObstacle", "fig8": "ArmObstacle"}
BAND_LABEL = "shaded: ± std over runs (in the line's colour)"
"""The curves' legend entry of the bands."""
TILE_LABEL = "-log10(p)·sign(t); red: A higher, blue: B higher"
"""The tiles' colour bar (row ``A vs B``)."""


def metric_of(run: RunData, metric: str = METRIC) -> str:
    """``metric`` if ``run`` recorded it; for the default metric, else the first recorded
    fallback (runs without an ``eval_env_return`` column)."""
    for column in (metric, *FALLBACK_METRICS) if metric == METRIC else (metric,):
        if run.has(column):
            return column
    raise ValueError(f"{run.path} has no column {metric!r} with values (see its metrics.csv)")


def stage_scores(curves: Mapping[str, np.ndarray], n_stages: int = N_STAGES
                 ) -> dict[str, np.ndarray]:
    """Each method's (seeds, points) curve as (seeds, stages) block means; curves are cut to
    the shortest one, blocks are contiguous and as equal as possible (``np.array_split``)."""
    n = min(v.shape[1] for v in curves.values())
    stages = max(1, min(n_stages, n))
    return {m: np.stack([b.mean(axis=1) for b in np.array_split(v[:, :n], stages, axis=1)],
                        axis=1) for m, v in curves.items()}


def stage_bounds(episodes: np.ndarray, n_stages: int) -> list[tuple[int, int]]:
    """(first, last) episode of every stage, blocks as in :func:`stage_scores`."""
    stages = max(1, min(n_stages, len(episodes)))
    return [(int(b[0]), int(b[-1])) for b in np.array_split(np.asarray(episodes), stages)]


@dataclass
class Comparison:
    """Methods' curves, stage scores and tests on one task."""

    metric: str
    episodes: np.ndarray
    curves: dict[str, np.ndarray]
    scores: dict[str, np.ndarray]
    bounds: list[tuple[int, int]]
    welch: stats.PairwiseWelch | None
    """``None`` when a method has fewer than two runs."""

    @property
    def methods(self) -> list[str]:
        return list(self.curves)

    def final(self) -> dict[str, np.ndarray]:
        """Each run's score at the last stage: the final return."""
        return {m: s[:, -1] for m, s in self.scores.items()}


def compare(runs: Mapping[str, RunData], metric: str = METRIC, n_stages: int = N_STAGES
            ) -> Comparison:
    """Curves, stage scores and pairwise Welch tests of ``runs`` (label -> run)."""
    if not runs:
        raise ValueError("no runs to compare")
    series = {label: run.series(metric_of(run, metric)) for label, run in runs.items()}
    n = min(values.shape[1] for _, values in series.values())
    episodes = next(iter(series.values()))[0][:n]
    curves = {label: values[:, :n] for label, (_, values) in series.items()}
    scores = stage_scores(curves, n_stages)
    enough = len(scores) >= 2 and all(s.shape[0] >= stats.MIN_RUNS_T_TEST
                                      for s in scores.values())
    welch = stats.pairwise_welch(scores) if enough else None
    used = {metric_of(r, metric) for r in runs.values()}
    return Comparison(" / ".join(sorted(used)), episodes, curves, scores,
                      stage_bounds(episodes, n_stages), welch)


def plot_comparison(comp: Comparison, title: str):
    """The Fig. 7/8 figure: curves (mean ± std) on top, their legend naming each method and
    the bands; tiles below, their colour bar naming the colours."""
    from matplotlib.patches import Patch

    plt = pyplot()
    pairs = _pairs(comp)
    fig, (top, bottom) = plt.subplots(
        2, 1, figsize=(9, 5.5 + 0.35 * len(pairs)),
        gridspec_kw={"height_ratios": [3, max(1, 0.45 * len(pairs))]})
    for label, values in comp.curves.items():
        mean, std = values.mean(axis=0), values.std(axis=0, ddof=1) if len(values) > 1 else 0
        (line,) = top.plot(comp.episodes, mean, label=f"{label}: mean of {len(values)} runs")
        top.fill_between(comp.episodes, mean - std, mean + std, color=line.get_color(),
                         alpha=0.2, linewidth=0)
    top.set(xlabel="training episode", ylabel=f"episode return ({comp.metric})", title=title)
    handles, _ = top.get_legend_handles_labels()
    band = Patch(color="0.5", alpha=0.3, linewidth=0, label=BAND_LABEL)
    top.legend(handles=[*handles, band], loc="lower right", fontsize=8)
    if comp.welch is None or not pairs:
        bottom.text(0.5, 0.5, "t-tests need at least two methods with two runs each",
                    ha="center", va="center", transform=bottom.transAxes)
        bottom.set_axis_off()
    else:
        _draw_tiles(bottom, comp, pairs)
    fig.tight_layout()
    return fig


def _pairs(comp: Comparison) -> list[tuple[str, str]]:
    m = comp.methods
    return [(m[i], m[j]) for i in range(len(m)) for j in range(i + 1, len(m))]


def _draw_tiles(ax, comp: Comparison, pairs: list[tuple[str, str]]) -> None:
    welch = comp.welch
    tiles = np.array([welch.tile(a, b) for a, b in pairs])
    shown = np.clip(np.nan_to_num(tiles, posinf=COLOUR_LIMIT, neginf=-COLOUR_LIMIT),
                    -COLOUR_LIMIT, COLOUR_LIMIT)
    image = ax.imshow(shown, cmap="RdBu_r", vmin=-COLOUR_LIMIT, vmax=COLOUR_LIMIT,
                      aspect="auto")
    for r, (a, b) in enumerate(pairs):
        i, j = welch.methods.index(a), welch.methods.index(b)
        for s in range(tiles.shape[1]):
            mark = "*" if welch.p_holm[i, j, s] < ALPHA else ""
            ink = "white" if abs(shown[r, s]) > COLOUR_LIMIT * 0.6 else "black"
            ax.text(s, r, f"{welch.p[i, j, s]:.2g}{mark}", ha="center", va="center", fontsize=6,
                    color=ink)
    ax.set_yticks(range(len(pairs)), [f"{a} vs {b}" for a, b in pairs], fontsize=7)
    ax.set_ylabel("A vs B", fontsize=7)
    ax.set_xticks(range(len(comp.bounds)), [f"{lo}-{hi}" for lo, hi in comp.bounds],
                  fontsize=6, rotation=45)
    ax.set_xlabel("training stage (episodes); tile text: p, * Holm-adjusted p < 0.05")
    bar = ax.figure.colorbar(image, ax=ax, fraction=0.03, pad=0.01)
    bar.set_label(TILE_LABEL, fontsize=7)


def summary_numbers(comp: Comparison) -> dict:
    """Final return per method (mean, std, IQM with 95% CI, n), and per pair the last-stage
    Welch test, Holm-adjusted p, probability of improvement and the count of stages where the
    first method is significantly better / worse (Holm)."""
    final = comp.final()
    out: dict = {"metric": comp.metric, "stages": comp.bounds,
                 "final": {m: stats.summarize(v) for m, v in final.items()}, "pairs": []}
    if comp.welch is None:
        return out
    w = comp.welch
    for a, b in _pairs(comp):
        i, j = w.methods.index(a), w.methods.index(b)
        sig = w.p_holm[i, j] < ALPHA
        out["pairs"].append({
            "a": a, "b": b, "t": float(w.t[i, j, -1]), "p": float(w.p[i, j, -1]),
            "p_holm": float(w.p_holm[i, j, -1]),
            "prob_improvement": stats.probability_of_improvement(final[a], final[b]),
            "stages_a_better": int((sig & (w.t[i, j] > 0)).sum()),
            "stages_b_better": int((sig & (w.t[i, j] < 0)).sum()),
        })
    return out


def summary_markdown(numbers: dict, success: Mapping[str, float] | None = None) -> str:
    """Two tables: final return per method; the tests per pair."""
    extra = " success rate |" if success else ""
    lines = [f"Final return = each run's mean {numbers['metric']} over the last stage "
             f"(episodes {numbers['stages'][-1][0]}-{numbers['stages'][-1][1]}).", "",
             f"| method | runs | seeds | final return (mean ± std) | IQM [95% CI] |{extra}",
             "|---|---:|---|---:|---:|" + ("---:|" if success else "")]
    seeds = numbers.get("seeds", {})
    for m, s in numbers["final"].items():
        rate = f" {fmt(success[m])} |" if success else ""
        held = ", ".join(seed_ranges(seeds[m])) if m in seeds else "-"
        lines.append(f"| {m} | {s['n']} | {held} | {fmt_pm(s['mean'], s['std'])} | "
                     f"{fmt_ci(s['iqm'], s['ci_low'], s['ci_high'])} |{rate}")
    if numbers["pairs"]:
        n_stages = len(numbers["stages"])
        lines += ["", "| pair (A vs B) | t (last stage) | p | p (Holm) | P(A > B) | "
                  f"stages A better / B better (Holm p < {ALPHA}, of {n_stages}) |",
                  "|---|---:|---:|---:|---:|---:|"]
        for p in numbers["pairs"]:
            lines.append(f"| {p['a']} vs {p['b']} | {fmt(p['t'])} | {fmt(p['p'], 3)} | "
                         f"{fmt(p['p_holm'], 3)} | {fmt(p['prob_improvement'])} | "
                         f"{p['stages_a_better']} / {p['stages_b_better']} |")
    return "\n".join(lines)


def run_comparison(ctx: Context, name: str, algos: Sequence[str] = COMPARED) -> dict:
    """Train or reuse every available method on ``FIGURES[name]``; write the figure and the
    report section; return the section. The methods this invocation does not train are
    looked up once its own training is done, so an artifact another invocation wrote
    meanwhile (one beside it, say) is drawn."""
    from hiddpg.experiments.arm import success_rates

    t0, task = time.perf_counter(), FIGURES[name]
    trained = {algo: ensure_run(ctx, algo, task) for algo in algos
               if ctx.trains(algo) and available(ctx, algo, task) is None}
    runs, notes = {}, []
    for algo in algos:  # the others' artifacts as they are now, after the training
        why = None if algo in trained else available(ctx, algo, task)
        if why:
            notes.append(f"{algo} is not available and was left out ({why}).")
            ctx.say(f"{name}: leaving out {algo}: {why}")
            continue
        run = load_run(trained.get(algo) or ensure_run(ctx, algo, task))
        runs[run.label] = run
        progress = run.progress()
        if progress.get("status") != "finished":
            notes.append(f"{run.label} stopped at episode {progress['episodes']} "
                         f"({progress.get('error', progress['status'])}); every curve and "
                         "stage is cut to the shortest run.")
    comp = compare(runs)
    title = f"Fig. {name[-1]}: {task}, {' vs '.join(runs)}"
    figures = save_figure(plot_comparison(comp, title), ctx.figure_stem(name),
                          ctx.note())
    numbers = summary_numbers(comp)
    numbers["seeds"] = {m: list(r.seeds) for m, r in runs.items()}
    success = success_rates(runs) if task_family(task) == "arm" else None
    if success:
        numbers["success_rate"] = success
    markdown = "\n".join([*notes, "" if notes else "", summary_markdown(numbers, success)])
    methods = f"{len(runs)} method" + ("" if len(runs) == 1 else "s")
    section = {"title": f"Fig. {name[-1]}: {methods} on {task}",
               "figures": [str(p.relative_to(ctx.out)) for p in figures],
               "markdown": markdown.strip(), "numbers": numbers,
               "runs": {m: str(r.path.relative_to(ctx.out)) for m, r in runs.items()},
               "wall_s": time.perf_counter() - t0}
    write_section(ctx, name, section)
    return section

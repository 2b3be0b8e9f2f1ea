"""The evaluation curves of a one-change-at-a-time study (``python -m
hiddpg.experiments.diagnosis ... --plot FILE.png [--only LABEL ...]``).

:func:`curves` computes what is drawn, from the same records as the table
(:func:`hiddpg.experiments.diagnosis.collect`): per run, the mean evaluation return over its
seeds and a 95% t band. :func:`plot_curves` draws them with horizontal reference lines. A
study with many rows can be drawn a few runs at a time (``only``: their labels, in the order
drawn).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np


def curves(paths: Sequence[str], at: int | None = None, labels: dict[str, str] | None = None,
           only: Sequence[str] | None = None) -> list[dict[str, Any]]:
    """One entry per run with an evaluation curve: ``run`` (its label), ``seeds``,
    ``episodes``, ``mean`` and ``half`` (the 95% t half-width over seeds), cut at ``at``.
    With ``only``, just those runs, in that order; a label no run has is an error naming the
    runs there are."""
    from scipy import stats

    from hiddpg.experiments.diagnosis import collect

    out = []
    for rec in collect(list(paths), at=at, labels=labels)["runs"]:
        if "eval_env_return" not in rec["eval"]:
            continue
        episodes = np.asarray(rec["eval_episodes"])
        values = np.asarray(rec["eval"]["eval_env_return"])
        keep = episodes <= (at or episodes[-1])
        episodes, values = episodes[keep], values[:, keep]
        mean, n = values.mean(axis=0), values.shape[0]
        half = (stats.t.ppf(0.975, n - 1) * values.std(axis=0, ddof=1) / np.sqrt(n)
                if n > 1 else np.zeros_like(mean))
        out.append({"run": rec["run"], "seeds": n, "episodes": episodes, "mean": mean,
                    "half": half})
    if only is None:
        return out
    by_label = {c["run"]: c for c in out}
    missing = [label for label in only if label not in by_label]
    if missing:
        raise ValueError(f"--only {missing[0]!r}: no run with an evaluation curve has this "
                         f"label; the runs are {list(by_label)}")
    return [by_label[label] for label in only]


def plot_curves(paths: Sequence[str], out: Path, at: int | None = None, title: str = "",
                lines: dict[str, float] | None = None, labels: dict[str, str] | None = None,
                only: Sequence[str] | None = None) -> Path:
    """The runs' evaluation curves (:func:`curves`) with horizontal reference ``lines``
    (label -> value), written to ``out``."""
    from hiddpg.experiments.report import pyplot

    plt = pyplot()
    fig, ax = plt.subplots(figsize=(8, 4.5))
    levels = list((lines or {}).values())
    for drawn, c in enumerate(curves(paths, at, labels, only)):
        levels += [float(c["mean"].min()), float(c["mean"].max())]
        # the colour cycle has ten colours: the next ten runs are dashed, so none look alike
        (line,) = ax.plot(c["episodes"], c["mean"], lw=1.2,
                          ls=("-", "--", "-.")[drawn // 10 % 3],
                          label=f"{c['run']} ({c['seeds']} seeds)")
        ax.fill_between(c["episodes"], c["mean"] - c["half"], c["mean"] + c["half"],
                        color=line.get_color(), alpha=0.15)
    for i, (label, value) in enumerate((lines or {}).items()):
        ax.axhline(value, color="k", lw=0.8, ls=("--", ":", "-.")[i % 3], label=label)
    if levels:  # the means and reference lines in view; a wide band may leave it
        span = max(levels) - min(levels) or 1.0
        ax.set_ylim(min(levels) - 0.1 * span, max(levels) + 0.1 * span)
    ax.set_xlabel("training episode")
    ax.set_ylabel("evaluation environment return")
    ax.set_title(title)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(0.0, -0.15))
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=120, bbox_inches="tight")
    plt.close(fig)
    return out

"""The curves and table of ``benchmarks/gym_demo.py`` from its records: every method's
finished records merged over seeds (ours: one record per part of seeds; SB3: one per seed),
mean +- std over seeds, and each method's final return against SB3 TD3's (Welch 95%)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

OURS, BASELINE = ("ddpg", "hi-ddpg", "h-ddpg"), "sb3-td3"
#: Every method of the demo, in the order of its curves and table.
ALL = (*OURS, "sb3-ddpg", BASELINE)


def read(path: Path) -> dict | None:
    return json.loads(path.read_text()) if path.is_file() else None


def curves(out: Path, methods: list[str]) -> dict[str, tuple[np.ndarray, np.ndarray, list]]:
    """Per method with a finished record: the evaluation steps, the (seed, evaluation) mean
    returns and the seeds, merged over its finished records (ours: parts of seeds; SB3: one
    record a seed), in seed order. Records evaluated at other steps than the first are an
    error (a part trained with other ``--episodes`` or ``--eval-every``)."""
    found = {}
    for m in methods:
        rows: dict[int, list[float]] = {}
        steps = None
        for f in sorted((out / "records" / m).glob("seed*.json")):
            rec = read(f)
            if m in OURS and not rec.get("finished"):
                print(f"{f}: not finished, left out", flush=True)
                continue
            these = [e["steps"] for e in rec["evals"]]
            if steps is not None and these != steps:
                raise SystemExit(f"{f}: evaluated at other steps than the other records of "
                                 f"{m} (--episodes or --eval-every differ)")
            steps = these
            means = np.array([np.mean(e["returns"], axis=-1) for e in rec["evals"]])
            for i, seed in enumerate(rec["seeds"] if m in OURS else [rec["seed"]]):
                rows[seed] = (means[:, i] if m in OURS else means).tolist()
        if rows:
            seeds = sorted(rows)
            found[m] = (np.asarray(steps), np.array([rows[s] for s in seeds]), seeds)
    return found


def table(found: dict[str, tuple[np.ndarray, np.ndarray, list]]) -> str:
    """:func:`curves`' final returns as a markdown table: per method its seeds, the steps of
    its last evaluation, the mean +- std over seeds of each seed's last evaluation (the mean of
    its evaluation episodes) and, with two seeds or more on both sides, the Welch 95% interval
    of its difference to SB3 TD3's."""
    from hiddpg.experiments.diagnosis import welch_interval
    from hiddpg.runner import seed_ranges

    lines = ["| method | seeds | env steps | final return (mean ± std) | vs SB3 TD3: "
             "difference [Welch 95%] |", "|---|---|---|---|---|"]
    base = found.get(BASELINE, (None, None, None))[1]
    for m, (steps, values, seeds) in found.items():
        final, vs = values[:, -1], ""
        if base is not None and m != BASELINE and len(final) > 1 and len(base) > 1:
            d, lo, hi = welch_interval(final, base[:, -1])
            vs = f"{d:+.3g} [{lo:+.3g}, {hi:+.3g}]"
        lines.append(f"| {m} | {','.join(seed_ranges(seeds))} | {steps[-1]} | {final.mean():.3g} ± "
                     f"{final.std(ddof=1) if len(final) > 1 else 0:.2g} | {vs} |")
    return "\n".join(lines) + "\n"


def summarize(out: Path, methods: list[str], title: str) -> None:
    """Writes ``out/curves.png`` (mean +- std over seeds) and ``out/table.md`` (:func:`table`)
    from the records under ``out``."""
    from hiddpg.experiments.report import pyplot

    found = curves(out, methods)
    if not found:
        return
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7, 4))
    for m, (steps, values, _) in found.items():
        mean, std = values.mean(0), values.std(0, ddof=1) if len(values) > 1 else 0 * values[0]
        (line,) = ax.plot(steps, mean, label=f"{m} ({len(values)} seeds)")
        ax.fill_between(steps, mean - std, mean + std, color=line.get_color(), alpha=0.15)
    ax.set(xlabel="environment steps per seed", ylabel="evaluation return", title=title)
    ax.legend(fontsize=8)
    fig.savefig(out / "curves.png", dpi=120, bbox_inches="tight")
    plt.close(fig)
    text = table(found)
    (out / "table.md").write_text(text)
    print(text + f"wrote {out / 'curves.png'}, {out / 'table.md'}")


if __name__ == "__main__":  # redraw from the records: python benchmarks/_demo_summary.py OUT
    import sys

    for arg in sys.argv[1:]:
        summarize(Path(arg), list(ALL), f"{Path(arg).name}: evaluation return, mean ± std "
                  "over seeds")

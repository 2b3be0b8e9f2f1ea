"""The curves and table of ``benchmarks/gym_demo.py`` from its records: every method's
finished records merged over seeds (ours: one record per part of seeds; SB3: one per seed),
mean +- std over seeds, and each method's final return against SB3 TD3's (Welch 95%)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

OURS, BASELINE = ("ddpg", "hi-ddpg", "h-ddpg"), "sb3-td3"


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


def summarize(out: Path, methods: list[str], title: str) -> None:
    from hiddpg.experiments.diagnosis import welch_interval
    from hiddpg.experiments.report import pyplot
    from hiddpg.runner import seed_ranges

    found = curves(out, methods)
    if not found:
        return
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7, 4))
    lines = ["| method | seeds | env steps | final return (mean ± std) | vs SB3 TD3: "
             "difference [Welch 95%] |", "|---|---|---|---|---|"]
    base = found.get(BASELINE, (None, None, None))[1]
    for m, (steps, values, seeds) in found.items():
        mean, std = values.mean(0), values.std(0, ddof=1) if len(values) > 1 else 0 * values[0]
        (line,) = ax.plot(steps, mean, label=f"{m} ({len(values)} seeds)")
        ax.fill_between(steps, mean - std, mean + std, color=line.get_color(), alpha=0.15)
        final, vs = values[:, -1], ""
        if base is not None and m != BASELINE and len(final) > 1 and len(base) > 1:
            d, lo, hi = welch_interval(final, base[:, -1])
            vs = f"{d:+.3g} [{lo:+.3g}, {hi:+.3g}]"
        lines.append(f"| {m} | {','.join(seed_ranges(seeds))} | {steps[-1]} | {final.mean():.3g} ± "
                     f"{final.std(ddof=1) if len(final) > 1 else 0:.2g} | {vs} |")
    ax.set(xlabel="environment steps per seed", ylabel="evaluation return", title=title)
    ax.legend(fontsize=8)
    fig.savefig(out / "curves.png", dpi=120, bbox_inches="tight")
    plt.close(fig)
    (out / "table.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines) + f"\nwrote {out / 'curves.png'}, {out / 'table.md'}")

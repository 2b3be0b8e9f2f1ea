"""A one-change-at-a-time study read back as a table: what each variant of a sweep learned.

For a sweep directory (``hiddpg sweep SPEC --out DIR``; its ``sweep.json`` names each run's
changes) or any run directories, :func:`summarize` gives one row per run with, over its seeds:

* ``eval_env_return``: the last noise-free evaluation's environment return, mean and std;
* ``env_return``: the training episodes' environment return over the last ``window`` episodes;
* ``switches`` of the last evaluation and HI-DDPG's ``reach_error`` (how far a segment ends
  from its goal, training, last ``window`` episodes);
* ``high_q_mean`` against ``return`` (the high critic's mean value of its batches against the
  high-level return the episodes got), and both levels' ``dq_da_norm`` (the action gradient's
  mean norm), where the run logged them.

:func:`markdown` writes the rows as a table. ``python -m hiddpg.experiments.diagnosis DIR``
prints it.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

from hiddpg.experiments.rundata import RunData, discover_runs, load_run

#: training columns averaged over the last ``window`` episodes of every seed
WINDOW_COLUMNS = ("env_return", "return", "reach_error", "high_q_mean", "high_dq_da_norm",
                  "low_dq_da_norm")


def changes(path: Path) -> str:
    """The run's changes as the sweep that made it lists them (``sweep.json`` next to it);
    ``paper`` for none, the run's name outside a sweep."""
    manifest = path.parent / "sweep.json"
    if manifest.is_file():
        entry = json.loads(manifest.read_text()).get("runs", {}).get(path.name)
        if entry is not None:
            return ", ".join(entry.get("sets", [])) or entry.get("preset", "")
    return path.name


def _last_eval(data: RunData, column: str) -> np.ndarray | None:
    if not data.has(column):
        return None
    _, values = data.series(column)
    return values[:, -1]


def row(data: RunData, window: int = 200) -> dict[str, Any]:
    """One run's summary (see the module docstring); values are ``(mean, std)`` over seeds."""
    out: dict[str, Any] = {"run": changes(data.path), "episodes": int(data.episodes[-1]),
                           "seeds": len(data.seeds)}
    for column in ("eval_env_return", "eval_switches"):
        last = _last_eval(data, column)
        if last is not None:
            out[column] = (float(last.mean()), float(last.std(ddof=1)) if len(last) > 1 else 0.0)
    for column in WINDOW_COLUMNS:
        if data.has(column):
            per_seed = np.nanmean(data.metrics[column][:, -window:], axis=1)
            out[column] = (float(per_seed.mean()),
                           float(per_seed.std(ddof=1)) if len(per_seed) > 1 else 0.0)
    return out


def summarize(paths: list[str] | tuple[str, ...], window: int = 200) -> list[dict[str, Any]]:
    """One :func:`row` per run directory among ``paths`` (directories are searched)."""
    return [row(load_run(p), window) for p in discover_runs(paths)]


def markdown(rows: list[dict[str, Any]]) -> str:
    """The rows as a Markdown table (``mean ± std`` cells, blank where a run lacks a column)."""
    columns = ["eval_env_return", "eval_switches", *WINDOW_COLUMNS]
    present = [c for c in columns if any(c in r for r in rows)]
    lines = ["| run | episodes | seeds | " + " | ".join(present) + " |",
             "|---|---|---|" + "---|" * len(present)]
    for r in rows:
        cells = [f"{r[c][0]:.3g} ± {r[c][1]:.2g}" if c in r else "" for c in present]
        lines.append(f"| {r['run']} | {r['episodes']} | {r['seeds']} | " + " | ".join(cells)
                     + " |")
    return "\n".join(lines)


if __name__ == "__main__":  # pragma: no cover
    print(markdown(summarize(sys.argv[1:] or ["."])))

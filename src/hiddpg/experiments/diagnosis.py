"""A one-change-at-a-time study read back as a table and curves: what each variant learned.

For a sweep directory (``hiddpg sweep SPEC --out DIR``; its ``sweep.json`` names each run's
changes) or any run directories, :func:`collect` reads every run, cut at episode ``at``, into
a small JSON-able record (:func:`record`): per seed, the evaluation curve of the environment
return and switches, and the means of the training columns over the last ``window`` episodes.
Everything else is computed from these records, so a study exported with ``--export`` (and
committed under ``results/``) gives the same table and curves without the run directories.

:func:`summarize` gives one row per run, over its seeds:

* ``score``: the mean of each seed's last :data:`LAST_EVALS` evaluations (less noisy than one),
  and ``vs_paper``: its difference to the unchanged run's (``paper``) with a Welch 95%
  interval (``vs_base`` with ``--base LABEL``: to the run of that label);
* ``eval_env_return`` and ``eval_switches``: the last noise-free evaluation; HI-DDPG's
  ``eval_high_q_start`` (the high critic's value of the evaluation's first choice) and
  ``eval_high_return_discounted`` (the discounted high-level return ``Σ_k γ_H^k f_k`` that
  value estimates), and ``critic_error``, their difference, each seed's mean over its last
  :data:`LAST_EVALS` evaluations: the critic's error at the start state, where positive
  optimistic;
* ``env_return``, ``return``, HI-DDPG's ``reach_error`` (how far a segment ends from its
  goal), ``high_q_mean`` (the high critic's mean value of its batches: segments from every
  point of an episode, so not comparable with an episode's return) and both levels'
  ``dq_da_norm`` (the action gradient's mean norm): training, last ``window`` episodes,
  where the run logged them;
* with ``--final`` (:mod:`hiddpg.experiments.outcome`), where the final policy ends: how many
  seeds succeed (``final_success``, on tasks with a success criterion: the arm tasks), end
  early (``final_ended_early``: a collision on ArmObstacle), and the last step's reward
  (``final_reward``), from one noise-free episode per seed replayed from the checkpoint.

``python -m hiddpg.experiments.diagnosis DIR|EXPORT.json ... [--at EPISODE] [--plot FILE.png]
[--only LABEL ...] [--export FILE.json] [--base LABEL] [--final]`` prints the table
(:func:`markdown`) and draws the evaluation curves (:mod:`hiddpg.experiments.diagnosis_plot`,
``--only``: of those runs only); given an exported study and run directories, it
adds the runs to the study's records (``--export`` the same file to keep them).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

from hiddpg.experiments import outcome
from hiddpg.experiments.diagnosis_plot import plot_curves
from hiddpg.experiments.rundata import ExperimentError, RunData, discover_runs, load_run

#: evaluations averaged per seed for ``score``
LAST_EVALS = 5
#: training columns averaged over the last ``window`` episodes of every seed
WINDOW_COLUMNS = ("env_return", "return", "reach_error", "high_q_mean", "high_dq_da_norm",
                  "low_dq_da_norm")
EVAL_COLUMNS = ("eval_env_return", "eval_switches", "eval_high_q_start",
                "eval_high_return_discounted")
#: the high critic's error at an evaluation's start state: its value of its first choice
#: minus the discounted high-level return the noise-free episode got
CRITIC_ERROR = ("eval_high_q_start", "eval_high_return_discounted")
#: the final policy's outcome (``--final``); counts of seeds, then the mean last reward
FINAL_COLUMNS = ("final_success", "final_ended_early", "final_reward")


def changes(path: Path) -> str:
    """The run's changes as the sweep that made it lists them (``sweep.json`` next to it;
    its budget ``episodes=N`` left out; a key set twice, by the spec and by its group, with
    the value that holds, the last), led by its preset unless that is ``paper``; ``paper``
    for none, the run's name outside a sweep."""
    manifest = path.parent / "sweep.json"
    if manifest.is_file():
        entry = json.loads(manifest.read_text()).get("runs", {}).get(path.name)
        if entry is not None:
            last = {s.partition("=")[0]: s for s in entry.get("sets", [])}
            sets = [s for s in last.values() if not s.startswith("episodes=")]
            preset = entry.get("preset", "")
            return ", ".join(([preset] if preset != "paper" or not sets else []) + sets)
    return path.name


def cut(data: RunData, at: int | None) -> RunData:
    """``data`` with its episodes after ``at`` dropped (``None``: unchanged)."""
    if at is None:
        return data
    keep = data.episodes <= at
    if not keep.any():
        raise ValueError(f"{data.path} has no episode <= {at}")
    return RunData(data.path, data.config, data.seeds, data.episodes[keep],
                   {k: v[:, keep] for k, v in data.metrics.items()})


def record(data: RunData, window: int = 200, label: str | None = None) -> dict[str, Any]:
    """What the table and the curves need of one run, as plain lists (JSON), labelled
    ``label`` (default: :func:`changes`)."""
    out: dict[str, Any] = {"run": label or changes(data.path), "name": data.path.name,
                           "algo": data.config.algo, "task": data.config.task,
                           "preset": data.config.preset, "seeds": list(data.seeds),
                           "episodes": int(data.episodes[-1]), "eval": {}, "window": {}}
    for column in EVAL_COLUMNS:
        if data.has(column):
            episodes, values = data.series(column)
            out["eval_episodes"] = episodes.astype(int).tolist()
            out["eval"][column] = values.tolist()
    for column in WINDOW_COLUMNS:
        if data.has(column):
            out["window"][column] = np.nanmean(data.metrics[column][:, -window:],
                                               axis=1).tolist()
    return out


def collect(paths: list[str] | tuple[str, ...], window: int = 200,
            at: int | None = None, labels: dict[str, str] | None = None,
            final: bool = False) -> dict[str, Any]:
    """The study's records: those of every exported study among ``paths`` (``.json`` files,
    as written), then one per run directory (directories are searched), cut at ``at``. An
    exported study added to must have been cut at the same ``at`` and averaged over the same
    ``window``; a run directory whose label an export already has replaces that record, so a
    study can be added to from runs trained at different times. ``labels``: run directory
    name -> its label in the table (instead of its changes); a name no run has is an error.
    ``final``: each run directory's record also gets its final policy's outcome
    (:func:`hiddpg.experiments.outcome.final_outcome`; its checkpoint must be at the cut)."""
    exports = [p for p in paths if str(p).endswith(".json")]
    dirs = [p for p in paths if not str(p).endswith(".json")]
    if exports and not dirs and len(exports) == 1:
        if labels:
            raise ValueError(f"--label: {exports[0]} is an exported study; it keeps the labels "
                             "it was exported with")
        return json.loads(Path(exports[0]).read_text())
    study: dict[str, Any] = {"at": at, "window": window, "last_evals": LAST_EVALS, "runs": []}
    for path in exports:
        old = json.loads(Path(path).read_text())
        for key in ("at", "window"):
            if old.get(key) != study[key]:
                raise ValueError(f"{path}: exported with {key}={old.get(key)}, not {study[key]} "
                                 f"as asked (--{key}); add to it with the same --{key}")
        if "base" in old:
            study.setdefault("base", old["base"])
        study["runs"].extend(old["runs"])
    labels, runs = labels or {}, []
    found = discover_runs(dirs) if dirs else []
    unknown = sorted(set(labels) - {p.name for p in found})
    if unknown:
        raise ValueError(f"--label {unknown[0]!r}: no run directory has this name; the runs "
                         f"are {[p.name for p in found]}")
    for path in found:
        try:
            data = load_run(path)
        except ExperimentError as err:  # a run that has not finished a chunk yet
            print(f"skipped: {err}", file=sys.stderr)
            continue
        rec = record(cut(data, at), window, labels.get(path.name))
        if final:
            rec["final"] = outcome.final_outcome(path, rec["episodes"])
        runs.append(rec)
    fresh = {r["run"] for r in runs}
    study["runs"] = [r for r in study["runs"] if r["run"] not in fresh] + runs
    return study


def welch_interval(a: np.ndarray, b: np.ndarray, level: float = 0.95
                   ) -> tuple[float, float, float]:
    """``mean(a) - mean(b)`` and its Welch t interval (unequal variances)."""
    from scipy import stats

    va, vb = a.var(ddof=1) / len(a), b.var(ddof=1) / len(b)
    diff, se = float(a.mean() - b.mean()), float(np.sqrt(va + vb))
    if se == 0.0:
        return diff, diff, diff
    df = (va + vb) ** 2 / (va**2 / (len(a) - 1) + vb**2 / (len(b) - 1))
    half = float(stats.t.ppf(0.5 + level / 2, df)) * se
    return diff, diff - half, diff + half


def _spread(values: np.ndarray) -> tuple[float, float]:
    return float(values.mean()), float(values.std(ddof=1)) if len(values) > 1 else 0.0


def row(rec: dict[str, Any]) -> dict[str, Any]:
    """One run's summary (see the module docstring); values are ``(mean, std)`` over seeds;
    ``_scores`` holds the per-seed scores."""
    out: dict[str, Any] = {"run": rec["run"], "episodes": rec["episodes"],
                           "seeds": len(rec["seeds"])}
    for column, values in rec["eval"].items():
        out[column] = _spread(np.asarray(values)[:, -1])
        if column == "eval_env_return":
            per_seed = np.asarray(values)[:, -LAST_EVALS:].mean(axis=1)
            out["score"], out["_scores"] = _spread(per_seed), per_seed
    if all(c in rec["eval"] for c in CRITIC_ERROR):
        q, ret = (np.asarray(rec["eval"][c])[:, -LAST_EVALS:] for c in CRITIC_ERROR)
        out["critic_error"] = _spread((q - ret).mean(axis=1))
    for column, per_seed in rec["window"].items():
        out[column] = _spread(np.asarray(per_seed))
    if "final" in rec:
        out.update(outcome.summary(rec["final"]))
    return out


def summarize(paths: list[str] | tuple[str, ...], window: int = 200,
              at: int | None = None, base: str | None = None,
              labels: dict[str, str] | None = None, final: bool = False
              ) -> list[dict[str, Any]]:
    """One :func:`row` per run of :func:`collect`; where the run labelled ``base`` is among
    them, the others get their difference to it: ``vs_paper`` for the unchanged paper run,
    ``vs_base`` for another base (e.g. ``"quick, agent.choice=actor"``). ``base`` defaults to
    the one an exported study names, else ``paper``. ``final``: as :func:`collect`."""
    study = collect(paths, window, at, labels, final)
    base = base or study.get("base") or "paper"
    rows = [row(r) for r in study["runs"]]
    ref = next((r for r in rows if r["run"] == base and "_scores" in r), None)
    key = "vs_paper" if base == "paper" else "vs_base"
    for r in rows:
        if ref is not None and r is not ref and "_scores" in r and len(r["_scores"]) > 1:
            r[key] = welch_interval(r["_scores"], ref["_scores"])
    return rows


def markdown(rows: list[dict[str, Any]]) -> str:
    """The rows as a Markdown table (``mean ± std`` cells, blank where a run lacks a column)."""
    columns = ["score", "vs_paper", "vs_base", *EVAL_COLUMNS, "critic_error",
               *FINAL_COLUMNS, *WINDOW_COLUMNS]
    present = [c for c in columns if any(c in r for r in rows)]
    lines = ["| run | episodes | seeds | " + " | ".join(present) + " |",
             "|---|---|---|" + "---|" * len(present)]
    for r in rows:
        cells = [_cell(r, c) for c in present]
        lines.append(f"| {r['run']} | {r['episodes']} | {r['seeds']} | " + " | ".join(cells)
                     + " |")
    return "\n".join(lines)


def _cell(r: dict[str, Any], column: str) -> str:
    if column not in r:
        return ""
    if column in ("vs_paper", "vs_base"):
        diff, low, high = r[column]
        return f"{diff:+.3g} [{low:+.3g}, {high:+.3g}]"
    if column in FINAL_COLUMNS[:2]:
        return f"{r[column][0]}/{r[column][1]}"
    return f"{r[column][0]:.3g} ± {r[column][1]:.2g}"


def parse_labels(items: list[str], names: list[str]) -> dict[str, str]:
    """``--label NAME=LABEL`` items as run directory name -> label. A sweep's run names hold
    ``=`` (``...-agent.model_masked=false-bf7a88b5``), so ``NAME`` is the longest prefix before
    an ``=`` that is one of ``names``, else the text before the first ``=`` (which
    :func:`collect` then reports as no run's name)."""
    labels = {}
    for item in items:
        cuts = [i for i, ch in enumerate(item) if ch == "="]
        known = [item[:i] for i in cuts if item[:i] in names]
        name = max(known, key=len) if known else item.partition("=")[0]
        label = item[len(name) + 1:]
        if not cuts or not name or not label:
            raise ValueError(f"--label {item!r}: expected NAME=LABEL (a run directory's name)")
        labels[name] = label
    return labels


def main(argv: list[str] | None = None) -> int:
    """The command line; a bad directory, record or ``--line`` is one line on stderr, exit 2."""
    try:
        _main(argv)
    except (ExperimentError, ValueError, OSError) as err:
        print(f"python -m hiddpg.experiments.diagnosis: {err}", file=sys.stderr)
        return 2
    return 0


def _main(argv: list[str] | None) -> None:
    p = argparse.ArgumentParser(prog="python -m hiddpg.experiments.diagnosis",
                                description="A one-change-at-a-time study as a table.")
    p.add_argument("dirs", nargs="+",
                   help="sweep or run directories and exported .json studies (added together)")
    p.add_argument("--at", type=int, default=None, help="cut every run at this episode")
    p.add_argument("--window", type=int, default=200, help="training episodes averaged")
    p.add_argument("--plot", type=Path, default=None, help="also draw the curves here")
    p.add_argument("--export", type=Path, default=None,
                   help="write the study's records here (JSON; the table and curves read it)")
    p.add_argument("--title", default="")
    p.add_argument("--base", default=None, metavar="LABEL",
                   help="the run the others are compared with (vs_base; default: the one "
                        "an exported study names, else paper); --export records it")
    p.add_argument("--only", action="append", default=None, metavar="LABEL",
                   help="draw only the run of this label (repeatable: in the order drawn); "
                        "the table keeps every run")
    p.add_argument("--line", action="append", default=[], metavar="LABEL=VALUE",
                   help="a horizontal reference line on the plot (repeatable)")
    p.add_argument("--final", action="store_true",
                   help="also replay each run directory's final policy from "
                        "its checkpoint (one noise-free episode per seed; the checkpoint must "
                        "be at --at) and record where it ends (success, early end, last "
                        "reward)")
    p.add_argument("--label", action="append", default=[], metavar="NAME=LABEL",
                   help="label the run in directory NAME so in the table, the curves and an "
                        "export (default: its changes; repeatable)")
    args = p.parse_args(argv)
    if args.only and not args.plot:
        raise ValueError(f"--only {args.only[0]!r}: chooses the runs drawn; give --plot FILE.png")
    dirs = [p for p in args.dirs if not str(p).endswith(".json")]
    labels = parse_labels(args.label, [p.name for p in discover_runs(dirs)] if dirs else [])
    lines = {}
    for item in args.line:
        label, _, value = item.rpartition("=")
        try:
            lines[label] = float(value)
        except ValueError:
            raise ValueError(f"--line {item!r}: expected LABEL=NUMBER") from None
    source, final = args.dirs, args.final
    if args.export:
        study = collect(args.dirs, args.window, args.at, labels, final=args.final)
        if args.base not in (None, "paper"):
            study["base"] = args.base
        args.export.parent.mkdir(parents=True, exist_ok=True)
        args.export.write_text(json.dumps(study, indent=1) + "\n")
        print(f"wrote {args.export}")
        source, labels, final = [str(args.export)], {}, False  # the export holds it
    rows = summarize(source, args.window, args.at, args.base, labels, final)
    if args.base is not None and not any(r["run"] == args.base for r in rows):
        raise ValueError(f"--base {args.base!r}: no run has this label; the runs are "
                         f"{[r['run'] for r in rows]}")
    print(markdown(rows))
    if args.plot:
        out = plot_curves(source, args.plot, args.at, args.title, lines, labels, args.only)
        print(f"wrote {out}")


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

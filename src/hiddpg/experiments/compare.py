"""Two groups of runs compared on one per-seed number, across exported study records.

A study record (:mod:`hiddpg.experiments.diagnosis`, ``--export``) compares its runs with one
base run of the same record. A decision often needs more: the same setting measured on two
draws of seeds kept in two records (seeds 100-104 in one, 105-109 in another), pooled, against
another pooled group. :func:`seed_values` reads one run's per-seed values of a metric from a
record; :func:`compare` pools the runs named for each side and gives the difference of the
means with its Welch 95% interval (:func:`hiddpg.experiments.diagnosis.welch_interval`).

Metrics (each seed's mean over its last :data:`~hiddpg.experiments.diagnosis.LAST_EVALS`
evaluations, as the records' tables): ``score`` (the environment return), ``critic_error``
(the high critic's value of the first choice minus the discounted return it got) and
``abs_critic_error`` (its size).

``python -m hiddpg.experiments.compare --a RECORD LABEL [--a ...] --b RECORD LABEL [--b ...]
[--metric score]`` prints both sides' values per seed and ``mean(a) - mean(b) [low, high]``.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

from hiddpg.experiments.diagnosis import CRITIC_ERROR, LAST_EVALS, welch_interval

METRICS = ("score", "critic_error", "abs_critic_error")


def seed_values(record: str | Path, label: str, metric: str = "score") -> np.ndarray:
    """The per-seed ``metric`` of the run labelled ``label`` in the exported ``record``."""
    if metric not in METRICS:
        raise ValueError(f"metric {metric!r}: choose one of {list(METRICS)}")
    runs = json.loads(Path(record).read_text())["runs"]
    found = [r for r in runs if r["run"] == label]
    if not found:
        raise ValueError(f"{record}: no run labelled {label!r}; its runs are "
                         f"{[r['run'] for r in runs]}")
    evals = found[0]["eval"]
    if metric == "score":
        return np.asarray(evals["eval_env_return"])[:, -LAST_EVALS:].mean(axis=1)
    if not all(c in evals for c in CRITIC_ERROR):
        raise ValueError(f"{record}: the run {label!r} has no {CRITIC_ERROR[0]} (it predates "
                         "the metric); critic_error cannot be computed")
    q, ret = (np.asarray(evals[c])[:, -LAST_EVALS:] for c in CRITIC_ERROR)
    error = (q - ret).mean(axis=1)
    return np.abs(error) if metric == "abs_critic_error" else error


def compare(a: list[tuple[str, str]], b: list[tuple[str, str]], metric: str = "score"
            ) -> dict[str, Any]:
    """Each side's ``(record, label)`` runs pooled seed by seed: ``{"a", "b"}`` (the values),
    and ``"diff"``, ``"low"``, ``"high"``: ``mean(a) - mean(b)`` with its Welch 95% interval."""
    if not a or not b:
        raise ValueError("compare needs at least one run on each side (--a and --b)")
    va = np.concatenate([seed_values(rec, label, metric) for rec, label in a])
    vb = np.concatenate([seed_values(rec, label, metric) for rec, label in b])
    if len(va) < 2 or len(vb) < 2:
        raise ValueError(f"a Welch interval needs two seeds a side, not {len(va)} and {len(vb)}")
    diff, low, high = welch_interval(va, vb)
    return {"a": va, "b": vb, "diff": diff, "low": low, "high": high}


def _main(argv: list[str] | None) -> None:
    p = argparse.ArgumentParser(prog="python -m hiddpg.experiments.compare",
                                description=__doc__.splitlines()[0])
    p.add_argument("--a", nargs=2, action="append", default=[], metavar=("RECORD", "LABEL"),
                   help="a run of the first group (repeatable: pooled)")
    p.add_argument("--b", nargs=2, action="append", default=[], metavar=("RECORD", "LABEL"),
                   help="a run of the second group (repeatable: pooled)")
    p.add_argument("--metric", default="score", choices=METRICS)
    args = p.parse_args(argv)
    for record, _ in args.a + args.b:
        if not Path(record).is_file():
            raise ValueError(f"{record}: no such record (an exported study's .json)")
    out = compare([tuple(x) for x in args.a], [tuple(x) for x in args.b], args.metric)
    for side in ("a", "b"):
        values = ", ".join(f"{v:+.2f}" for v in out[side])
        print(f"{side}: {args.metric} per seed {values}; mean {out[side].mean():+.2f}")
    print(f"a - b: {out['diff']:+.2f} [{out['low']:+.2f}, {out['high']:+.2f}] (Welch 95%)")


def main(argv: list[str] | None = None) -> int:
    """The command line; a bad record, label or metric is one line on stderr, exit 2."""
    try:
        _main(argv)
    except (ValueError, KeyError, json.JSONDecodeError) as err:
        print(f"python -m hiddpg.experiments.compare: {err}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

"""Checking a run directory's files before they are trusted, and recovering what can be.

:func:`load_state` reads a checkpoint against the state structure of the run's config (from
``jax.eval_shape``: nothing is compiled) and names the file and the first mismatch.
:func:`scan_metrics` reads metrics.csv and says, per seed, up to which episode its history is
complete. :func:`plan_resume` combines both: which checkpoint a resumed run continues from,
which metrics rows past it are dropped, and what it tells the user; it raises
:class:`~hiddpg.run_files.RunFileError` when the run's history cannot be continued honestly
(a missing or short metrics.csv, no loadable checkpoint), so nothing is overwritten.
"""

from __future__ import annotations

import csv
import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import jax
import numpy as np
from flax import serialization

from hiddpg.run_files import RunFileError, atomic_write, remove_stale_temporaries
from hiddpg.stopping import writing

#: metrics.csv's leading columns that a row must have.
REQUIRED_COLUMNS = ("seed", "episode", "env_steps")


def read_raw(path: Path) -> dict[str, Any]:
    """The checkpoint's msgpack state dict; :class:`RunFileError` if it is not one."""
    try:
        raw = serialization.msgpack_restore(path.read_bytes())
    except Exception as err:  # msgpack raises several unrelated types for garbage
        raise RunFileError(path, f"is not a readable checkpoint ({type(err).__name__}: {err})",
                           _CHECKPOINT_REMEDY) from None
    if not isinstance(raw, dict) or "episode" not in raw:
        raise RunFileError(path, "is not a checkpoint of a run (no episode counter)",
                           _CHECKPOINT_REMEDY)
    done = np.asarray(raw["episode"])
    if done.size == 0 or not (done == done.flat[0]).all():
        raise RunFileError(path, f"holds seeds at different episodes {done.tolist()}",
                           _CHECKPOINT_REMEDY)
    return raw


_CHECKPOINT_REMEDY = ("restore it from a backup, or start a new run with the same config "
                      "(the metrics here stay readable)")


def raw_episodes(raw: dict[str, Any]) -> int:
    return int(np.asarray(raw["episode"]).flat[0])


def load_state(path: Path, shapes: Any) -> tuple[Any, int]:
    """The checkpoint at ``path`` as a state of the structure ``shapes`` (a pytree of
    ``jax.ShapeDtypeStruct``, e.g. ``jax.eval_shape(trainer.init_seeds, keys)``) and its
    episodes done. Raises :class:`RunFileError` naming the first leaf that does not match."""
    raw = read_raw(path)
    try:
        state = serialization.from_state_dict(shapes, raw)
    except (ValueError, KeyError, TypeError) as err:
        raise RunFileError(path, f"does not match this run's config ({err})",
                           _CHECKPOINT_REMEDY) from None
    flat, _ = jax.tree_util.tree_flatten_with_path(state)
    want = jax.tree.leaves(shapes)
    if len(flat) != len(want):
        raise RunFileError(path, f"has {len(flat)} arrays where this run's config has "
                           f"{len(want)}", _CHECKPOINT_REMEDY)
    for (where, leaf), spec in zip(flat, want, strict=True):
        arr = np.asarray(leaf)
        if arr.shape != tuple(spec.shape) or arr.dtype != spec.dtype:
            raise RunFileError(
                path, f"{jax.tree_util.keystr(where)} is {arr.dtype}{list(arr.shape)} where "
                f"this run's config has {spec.dtype}{list(spec.shape)}", _CHECKPOINT_REMEDY)
    state = jax.tree.map(jax.numpy.asarray, state)
    return state, raw_episodes(raw)


CONFIG_REMEDY = ("restore it from a backup: it holds the run's config and seeds, without "
                  "which its checkpoint cannot be read; nothing was changed")


def read_meta(path: Path) -> dict[str, Any]:
    """config.json's content, checked to hold a config and seeds."""
    try:
        meta = json.loads(path.read_text())
    except (ValueError, UnicodeDecodeError) as err:
        raise RunFileError(path, f"is not valid JSON ({err})", CONFIG_REMEDY) from None
    if not isinstance(meta, dict) or not {"config", "seeds"} <= set(meta):
        raise RunFileError(path, "has no 'config' and 'seeds'", CONFIG_REMEDY)
    return meta


@dataclass
class MetricsScan:
    """What metrics.csv holds: its header, each seed's last consecutive episode (0 for none),
    and the rows past ``torn`` that are incomplete (a write cut short)."""

    header: list[str] | None
    last: dict[int, int]
    rows: int = 0
    torn: int = 0

    def complete_through(self) -> int:
        """The last episode every seed's history reaches without a gap."""
        return min(self.last.values()) if self.last else 0


def scan_metrics(path: Path, seeds: tuple[int, ...]) -> MetricsScan:
    """Check metrics.csv: the header, each row's seed and episode, and that every seed's
    episodes run 1, 2, 3, … with no gap or repeat. A missing file is an empty history; a
    torn last line is counted, not an error. Raises :class:`RunFileError` otherwise."""
    scan = MetricsScan(None, {s: 0 for s in seeds})
    if not path.is_file():
        return scan
    with open(path, newline="") as f:
        text = f.read()
    lines = text.splitlines(keepends=True)
    if not lines:
        return scan
    header = next(csv.reader([lines[0]]))
    missing = [c for c in REQUIRED_COLUMNS if c not in header]
    if missing:
        raise RunFileError(path, f"has no column(s) {missing} in its header",
                           _METRICS_REMEDY)
    scan.header = header
    i_seed, i_ep = header.index("seed"), header.index("episode")
    for number, line in enumerate(lines[1:], start=2):
        row = next(csv.reader([line]), [])
        if len(row) != len(header) or not line.endswith("\n"):
            if number == len(lines):  # a torn last line: a write cut short
                scan.torn += 1
                continue
            raise RunFileError(path, f"line {number} has {len(row)} fields where the header "
                               f"has {len(header)}", _METRICS_REMEDY)
        try:
            seed, episode = int(row[i_seed]), int(row[i_ep])
        except ValueError:
            raise RunFileError(path, f"line {number}: seed {row[i_seed]!r} or episode "
                               f"{row[i_ep]!r} is not an integer", _METRICS_REMEDY) from None
        if seed not in scan.last:
            raise RunFileError(path, f"line {number}: seed {seed} is not one of the run's "
                               f"seeds {list(seeds)}", _METRICS_REMEDY)
        if episode != scan.last[seed] + 1:
            what = "repeats" if episode <= scan.last[seed] else "skips to"
            raise RunFileError(path, f"line {number}: seed {seed} {what} episode {episode} "
                               f"after episode {scan.last[seed]}", _METRICS_REMEDY)
        scan.last[seed] = episode
        scan.rows += 1
    return scan


_METRICS_REMEDY = ("restore it from a backup; the run's history cannot be trusted as it is "
                   "(nothing was changed)")


@dataclass
class ResumePlan:
    """How a run directory continues: from ``checkpoint`` (a path) at ``episodes`` done,
    ``damaged`` files to move aside, ``restore`` (copy the previous checkpoint over the
    current one), and the ``notes`` to tell the user."""

    checkpoint: Path | None
    episodes: int
    metrics: MetricsScan
    damaged: list[Path] = field(default_factory=list)
    restore: bool = False
    notes: list[str] = field(default_factory=list)


def plan_resume(current: Path, previous: Path, metrics: Path, seeds: tuple[int, ...],
                shapes: Any) -> ResumePlan:
    """Decide where a run continues from (see the module docstring). ``current`` and
    ``previous`` are the checkpoint files, ``metrics`` is metrics.csv."""
    scan = scan_metrics(metrics, seeds)
    history = scan.complete_through()
    usable: dict[Path, int] = {}
    problems: dict[Path, RunFileError] = {}
    for path in (current, previous):
        if path.is_file():
            try:
                usable[path] = load_state(path, shapes)[1]
            except RunFileError as err:
                problems[path] = err
    if current in usable and usable[current] <= history:
        return ResumePlan(current, usable[current], scan)
    if current in usable:  # the history stops before the checkpoint
        lost = (f"{metrics.name} is missing" if not metrics.is_file() or scan.header is None
                else f"{metrics.name} ends at episode {history}")
        if previous in usable and 0 < usable[previous] <= history:
            plan = ResumePlan(previous, usable[previous], scan, damaged=[current],
                              restore=True)
            plan.notes.append(f"{lost}, before the checkpoint's episode {usable[current]}; "
                              f"continuing from the previous checkpoint at episode "
                              f"{usable[previous]}")
            return plan
        raise RunFileError(metrics, f"{lost.removeprefix(metrics.name + ' ')} but the "
                           f"checkpoint has {usable[current]} episodes: the training history "
                           "between is lost", "restore metrics.csv from a backup, or start a "
                           "new run; nothing was changed")
    # no usable current checkpoint
    if previous in usable and usable[previous] <= history:
        plan = ResumePlan(previous, usable[previous], scan, restore=True)
        if current in problems:
            plan.damaged.append(current)
            plan.notes.append(f"{problems[current].problem.capitalize()}: moved aside; "
                              f"continuing from the previous checkpoint at episode "
                              f"{usable[previous]}")
        else:
            plan.notes.append(f"{current.name} is missing (a write was cut short); continuing "
                              f"from the previous checkpoint at episode {usable[previous]}")
        return plan
    if current in problems:
        raise problems[current]
    if previous in problems:
        raise problems[previous]
    if scan.rows:
        raise RunFileError(current, f"is missing but {metrics.name} has {scan.rows} rows",
                           "restore the checkpoint from a backup, or start a new run; "
                           "nothing was changed")
    return ResumePlan(None, 0, scan)  # created, never checkpointed: starts from scratch


def apply_plan(run: Any, plan: ResumePlan) -> list[str]:
    """Carry out ``plan`` on ``run`` (a :class:`hiddpg.runs.Run` whose lock is held): damaged
    files moved aside (``NAME.damaged``, numbered if taken), the previous checkpoint restored,
    an unreadable progress.json rewritten, leftover temporary files removed. Returns the
    notes for the user; metrics past the checkpoint are dropped later, when training starts."""
    notes = list(plan.notes)
    with writing():
        for path in plan.damaged:
            aside = _free_name(path.with_name(path.name + ".damaged"))
            os.replace(path, aside)
            notes.append(f"the damaged file is kept as {aside}")
        if plan.restore and plan.checkpoint is not None:
            atomic_write(run.checkpoint_path, plan.checkpoint.read_bytes())
        remove_stale_temporaries(run.path)
        try:
            run.progress()
        except RunFileError as err:
            run.write_progress(plan.episodes, 0.0, "interrupted")
            notes.append(f"{err.path.name} {err.problem}: rewritten from the checkpoint "
                         f"(episode {plan.episodes}; wall time counts from 0)")
    return notes


def _free_name(path: Path) -> Path:
    if not path.exists():
        return path
    n = 2
    while path.with_name(f"{path.name}.{n}").exists():
        n += 1
    return path.with_name(f"{path.name}.{n}")


def find_non_finite(train: dict[str, np.ndarray], seeds: tuple[int, ...]
                    ) -> tuple[str, int, int] | None:
    """The first ``(metric, seed, episode)`` whose loss metric (a key containing ``loss``) is
    NaN or infinite, in episode order; ``None`` if all are finite."""
    first = None
    for k in sorted(train):
        if "loss" not in k:
            continue
        bad = ~np.isfinite(np.asarray(train[k], dtype=np.float64))
        for i, e in zip(*np.nonzero(bad), strict=True):
            hit = (int(train["episode"][i, e]), k, seeds[i])
            first = hit if first is None or hit < first else first
    return None if first is None else (first[1], first[2], first[0])

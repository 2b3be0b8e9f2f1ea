"""Evaluation snapshots: one noise-free evaluation episode per seed after every chunk.

A run directory stores each as ``snapshots/episode_NNNNNN.npz`` (:func:`write_snapshot`); an
artifact stores them all in one JSON document (:func:`snapshots_to_json`) that keeps what the
figures read:

* ``metrics`` (per seed) and the trajectories ``alive``, ``switch``, ``goal`` and ``reward``
  exactly (each float32 written with the fewest digits that read back to the same value);
* ``action`` exactly, in the final snapshot only (Fig. 5 draws the final policy's actions);
* ``next_obs`` and ``obs`` cut to their first :data:`POSITION_DIMS` components (the puck's
  position, the arm's joint angles) and rounded to :data:`POSITION_DIGITS` significant digits;
  ``obs`` holds the first step only (the figures draw the start and every ``next_obs``).

Arrays that change at few steps (``alive``, ``switch``, ``goal``) are stored as their changes:
per seed a list of ``[step, value...]`` where the value differs from the step before. So every
number the figures compute from a snapshot is the same from either form.
"""

from __future__ import annotations

import io
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

SNAPSHOT_DIR = "snapshots"
EVAL_KEY = 0
"""Evaluation key of the snapshots (that of ``hiddpg eval --key 0``)."""
SNAPSHOT_FORMAT = "hiddpg-snapshots/1"
POSITION_DIMS = 2
POSITION_DIGITS = 5
EXACT_KEYS = ("alive", "switch", "goal", "reward")
CHANGE_KEYS = ("alive", "switch", "goal")
POSITION_KEYS = ("obs", "next_obs")
FINAL_KEYS = ("action",)


@dataclass(frozen=True)
class Snapshot:
    """One snapshot: ``metrics[k]`` (seeds,), ``traj[k]`` (seeds, horizon, ...)."""

    episode: int
    metrics: dict[str, np.ndarray]
    traj: dict[str, np.ndarray]


def snapshot_name(episodes: int) -> str:
    return f"episode_{episodes:06d}.npz"


def load_snapshot(path: Path) -> Snapshot:
    with np.load(path) as z:
        metrics = {k[7:]: z[k] for k in z.files if k.startswith("metric_")}
        traj = {k[5:]: z[k] for k in z.files if k.startswith("traj_")}
        return Snapshot(int(z["episode"]), metrics, traj)


def load_snapshot_dir(path: Path) -> list[Snapshot]:
    """Every snapshot of the run directory ``path``, in episode order."""
    return [load_snapshot(p) for p in sorted((path / SNAPSHOT_DIR).glob("episode_*.npz"))]


def write_snapshot(run: Any) -> Path:
    """Evaluate the checkpointed policies of ``run`` (a :class:`hiddpg.runs.Run`; one
    noise-free episode per seed) and store metrics and trajectories in
    ``snapshots/episode_NNNNNN.npz``."""
    from hiddpg.runs import atomic_write, make_trainer
    from hiddpg.train import eval_keys

    trainer = make_trainer(run.config)
    state, done = run.load_checkpoint(trainer)
    metrics, traj = trainer.evaluate_seeds(state, eval_keys(EVAL_KEY, run.seeds))
    arrays = {f"metric_{k}": np.asarray(v) for k, v in metrics.items()}
    arrays.update({f"traj_{k}": np.asarray(v) for k, v in traj.items()})
    buf = io.BytesIO()
    np.savez_compressed(buf, episode=np.asarray(done), **arrays)
    target = run.path / SNAPSHOT_DIR / snapshot_name(done)
    target.parent.mkdir(exist_ok=True)
    atomic_write(target, buf.getvalue())
    return target


# ------------------------------------------------------------------------------------ JSON


def snapshots_to_json(snaps: list[Snapshot]) -> str:
    """The JSON document of ``snaps`` (one snapshot a line)."""
    head = {"format": SNAPSHOT_FORMAT, "position_dims": POSITION_DIMS,
            "position_digits": POSITION_DIGITS,
            "exact": [*EXACT_KEYS, *FINAL_KEYS, "metrics"], "final_only": list(FINAL_KEYS)}
    lines = [json.dumps(_encode_snapshot(s, final=k == len(snaps) - 1), separators=(",", ":"))
             for k, s in enumerate(snaps)]
    text = json.dumps(head, separators=(",", ":"))[:-1]
    return text + ',"snapshots":[\n' + ",\n".join(lines) + "\n]}\n"


def snapshots_from_json(text: str) -> list[Snapshot]:
    """The snapshots of a document written by :func:`snapshots_to_json`."""
    doc = json.loads(text)
    if doc.get("format") != SNAPSHOT_FORMAT:
        raise ValueError(f"format {doc.get('format')!r} is not {SNAPSHOT_FORMAT!r}")
    return [Snapshot(int(s["episode"]),
                     {k: _decode(v) for k, v in s["metrics"].items()},
                     {k: _decode(v) for k, v in s["traj"].items()}) for s in doc["snapshots"]]


def _encode_snapshot(snap: Snapshot, final: bool) -> dict:
    traj = {}
    for key, value in snap.traj.items():
        value = np.asarray(value)
        if key in CHANGE_KEYS:
            traj[key] = _encode(value, changes=True)
        elif key in EXACT_KEYS or (final and key in FINAL_KEYS):
            traj[key] = _encode(value)
        elif key in POSITION_KEYS:
            cut = value[:, :1] if key == "obs" else value
            traj[key] = _encode(cut[..., :POSITION_DIMS], digits=POSITION_DIGITS)
    metrics = {k: _encode(np.asarray(v)) for k, v in snap.metrics.items()}
    return {"episode": int(snap.episode), "metrics": metrics, "traj": traj}


def _numbers(a: np.ndarray, digits: int | None) -> np.ndarray:
    """``a`` as float64 values that JSON writes short: the shortest decimal that reads back to
    the same value (float32: its own shortest form), or ``digits`` significant digits."""
    if a.dtype == np.bool_ or np.issubdtype(a.dtype, np.integer):
        return a.astype(np.int64)
    flat = a.ravel()
    if digits is not None:
        text = [f"{x:.{digits}g}" for x in flat.astype(np.float64)]
    elif a.dtype == np.float32:
        text = flat.astype(str)
    else:
        return a.astype(np.float64)
    return np.array([float(t) for t in text]).reshape(a.shape)


def _encode(a: np.ndarray, changes: bool = False, digits: int | None = None) -> dict:
    out: dict[str, Any] = {"dtype": a.dtype.name, "shape": list(a.shape)}
    values = _numbers(a, digits)
    if not changes or a.ndim < 2:
        out["values"] = values.tolist()
        return out
    rows = values.reshape(a.shape[0], a.shape[1], -1)
    same = np.concatenate([np.zeros((rows.shape[0], 1), bool),
                           ((rows[:, 1:] == rows[:, :-1])
                            | (np.isnan(rows[:, 1:]) & np.isnan(rows[:, :-1]))).all(axis=2)],
                          axis=1)
    out["changes"] = [[[int(t), *rows[i, t].tolist()] for t in np.flatnonzero(~same[i])]
                      for i in range(rows.shape[0])]
    return out


def _decode(entry: dict) -> np.ndarray:
    shape, dtype = tuple(entry["shape"]), np.dtype(entry["dtype"])
    if "values" in entry:
        return np.asarray(entry["values"], dtype=np.float64).astype(dtype).reshape(shape)
    rows = np.zeros((shape[0], shape[1], int(np.prod(shape[2:], dtype=int))))
    for i, seed_changes in enumerate(entry["changes"]):
        for k, (t, *value) in enumerate(seed_changes):
            end = seed_changes[k + 1][0] if k + 1 < len(seed_changes) else shape[1]
            rows[i, int(t):int(end)] = value
    return rows.astype(dtype).reshape(shape)

"""Runs read back from disk: metrics.csv as arrays, evaluation snapshots, run discovery.

``RunData.metrics[column]`` is a (seeds, episodes) float array (NaN where a row has no value,
e.g. evaluation columns between evaluations); a :class:`Snapshot` is one noise-free evaluation
episode per seed stored by :func:`hiddpg.experiments.common.write_snapshot`.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from hiddpg.configs import TrainConfig
from hiddpg.runs import CONFIG_FILE, Run

SNAPSHOT_DIR = "snapshots"
LABELS = {"hi-ddpg": "HI-DDPG", "h-ddpg": "h-DDPG", "hi-ddpg-wo-model": "HI-DDPG-wo-model",
          "ddpg": "DDPG"}


class ExperimentError(RuntimeError):
    """An experiment cannot go on (a run failed, a run on disk has another config)."""


@dataclass(frozen=True)
class Snapshot:
    """One snapshot: ``metrics[k]`` (seeds,), ``traj[k]`` (seeds, horizon, ...)."""

    episode: int
    metrics: dict[str, np.ndarray]
    traj: dict[str, np.ndarray]


def load_snapshot(path: Path) -> Snapshot:
    with np.load(path) as z:
        metrics = {k[7:]: z[k] for k in z.files if k.startswith("metric_")}
        traj = {k[5:]: z[k] for k in z.files if k.startswith("traj_")}
        return Snapshot(int(z["episode"]), metrics, traj)


# ------------------------------------------------------------------------------- run data


@dataclass
class RunData:
    """A run directory read back: config, seeds, per-seed per-episode metrics, snapshots."""

    path: Path
    config: TrainConfig
    seeds: tuple[int, ...]
    episodes: np.ndarray
    """(episodes,) the training episodes 1..E present for every seed."""
    metrics: dict[str, np.ndarray]
    """column -> (seeds, episodes) floats; NaN where empty (non-evaluation rows)."""

    def env(self) -> tuple[Any, Any]:
        """The run's environment and its params (no agent is built)."""
        from hiddpg.envs import make

        return make(self.config.task, **self.config.env_overrides)

    @property
    def label(self) -> str:
        return LABELS.get(self.config.algo, self.config.algo)

    def has(self, column: str) -> bool:
        return column in self.metrics and bool(np.isfinite(self.metrics[column]).any())

    def series(self, column: str) -> tuple[np.ndarray, np.ndarray]:
        """``(episodes, values (seeds, points))`` of ``column``; evaluation columns keep only
        the evaluated episodes."""
        values = self.metrics[column]
        keep = np.isfinite(values).all(axis=0)
        return self.episodes[keep], values[:, keep]

    def snapshot_paths(self) -> list[Path]:
        return sorted((self.path / SNAPSHOT_DIR).glob("episode_*.npz"))

    def final_snapshot(self) -> Snapshot:
        paths = self.snapshot_paths()
        if not paths:
            raise ExperimentError(f"{self.path} has no snapshot; run `hiddpg reproduce` on it")
        return load_snapshot(paths[-1])


def load_run(path: str | Path) -> RunData:
    """Read ``path``'s config and metrics.csv into arrays (seeds, episodes)."""
    run = Run.open(path)
    if not run.metrics_path.is_file():
        raise ExperimentError(f"{run.path} has no {run.metrics_path.name} yet")
    with open(run.metrics_path, newline="") as f:
        rows = list(csv.DictReader(f))
    index = {s: i for i, s in enumerate(run.seeds)}
    per_seed: list[list[dict]] = [[] for _ in run.seeds]
    for row in rows:
        per_seed[index[int(row["seed"])]].append(row)
    n = min(len(r) for r in per_seed)
    if n == 0:
        raise ExperimentError(f"{run.path} has no finished episode yet")
    columns = [c for c in rows[0] if c != "seed"]
    metrics = {c: np.array([[_float(r[c]) for r in seed_rows[:n]] for seed_rows in per_seed])
               for c in columns}
    episodes = metrics.pop("episode")[0].astype(int)
    return RunData(run.path, run.config, run.seeds, episodes, metrics)


def _float(text: str) -> float:
    return float(text) if text not in ("", None) else float("nan")


def discover_runs(paths: list[str] | tuple[str, ...]) -> list[Path]:
    """Run directories among ``paths``: a run directory itself, or every run directory below
    a directory (sorted)."""
    found: list[Path] = []
    for p in map(Path, paths):
        if (p / CONFIG_FILE).is_file():
            found.append(p)
        elif p.is_dir():
            found += sorted(c.parent for c in p.rglob(CONFIG_FILE))
        else:
            raise ExperimentError(f"{p} is neither a run directory nor a directory of runs")
    return found

"""Runs read back from disk: a run directory or an artifact as arrays, run discovery.

``RunData.metrics[column]`` is a (seeds, points) float array (NaN where a row has no value,
e.g. evaluation columns between evaluations): one point per training episode for a run
directory, one per evaluation for an artifact (:mod:`hiddpg.experiments.artifacts`).
``RunData.training`` holds the training columns as means over blocks of episodes, the same
from either. A :class:`Snapshot` is one noise-free evaluation episode per seed
(:mod:`hiddpg.experiments.snapshots`).
"""

from __future__ import annotations

import csv
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from hiddpg.configs import TrainConfig
from hiddpg.experiments.snapshots import SNAPSHOT_DIR, Snapshot, load_snapshot, load_snapshot_dir
from hiddpg.runs import CONFIG_FILE, Run

__all__ = ["SNAPSHOT_DIR", "Snapshot", "load_snapshot", "RunData", "TrainingBlocks",
           "block_means", "load_run", "discover_runs", "ExperimentError"]

LABELS = {"hi-ddpg": "HI-DDPG", "h-ddpg": "h-DDPG", "hi-ddpg-wo-model": "HI-DDPG-wo-model",
          "ddpg": "DDPG"}
TRAINING_BLOCKS = 100
"""Training columns are kept as means over blocks of ``max(1, episodes // 100)`` episodes."""
TRAINING_COLUMNS = ("return", "switches")
"""The training (per-episode) columns the figures read."""


class ExperimentError(RuntimeError):
    """An experiment cannot go on (a run failed, a run on disk has another config)."""


@dataclass(frozen=True)
class TrainingBlocks:
    """Training columns averaged over blocks of ``size`` episodes, counted back from the last
    episode (the first ``episodes % size`` episodes are left out)."""

    size: int
    ends: np.ndarray
    """(blocks,) the last episode of each block."""
    means: dict[str, np.ndarray]
    """column -> (seeds, blocks) means."""


def block_size(episodes: int) -> int:
    return max(1, episodes // TRAINING_BLOCKS)


def block_means(episodes: np.ndarray, metrics: dict[str, np.ndarray],
                columns: tuple[str, ...] = TRAINING_COLUMNS) -> TrainingBlocks:
    """The :class:`TrainingBlocks` of per-episode ``metrics`` (columns of ``columns`` that
    are present), blocks of :func:`block_size` episodes."""
    n = len(episodes)
    size = block_size(n)
    blocks = n // size
    start = n - blocks * size
    means = {c: metrics[c][:, start:].reshape(len(metrics[c]), blocks, size).mean(axis=2)
             for c in columns if c in metrics}
    return TrainingBlocks(size, np.asarray(episodes[start + size - 1::size]), means)


# ------------------------------------------------------------------------------- run data


@dataclass
class RunData:
    """A run read back: config, seeds, per-seed metrics, training blocks, snapshots."""

    path: Path
    config: TrainConfig
    seeds: tuple[int, ...]
    episodes: np.ndarray
    """(points,) the episodes of ``metrics``, present for every seed."""
    metrics: dict[str, np.ndarray]
    """column -> (seeds, points) floats; NaN where empty (non-evaluation rows)."""
    blocks: TrainingBlocks | None = None
    """The training columns' block means; ``None``: computed from per-episode ``metrics``."""
    stored_snapshots: Callable[[], list[Snapshot]] | None = None
    """Reads the snapshots; ``None``: the npz files under ``path/snapshots``."""
    info: dict[str, Any] | None = None
    """The run's episodes, wall time and status; ``None``: its progress.json."""
    _snapshots: list[Snapshot] | None = field(default=None, init=False, repr=False)

    def env(self) -> tuple[Any, Any]:
        """The run's environment and its params (no agent is built)."""
        from hiddpg.envs import make

        return make(self.config.task, **self.config.env_overrides)

    @property
    def label(self) -> str:
        return LABELS.get(self.config.algo, self.config.algo)

    @property
    def training(self) -> TrainingBlocks:
        if self.blocks is None:
            self.blocks = block_means(self.episodes, self.metrics)
        return self.blocks

    def has(self, column: str) -> bool:
        return column in self.metrics and bool(np.isfinite(self.metrics[column]).any())

    def series(self, column: str) -> tuple[np.ndarray, np.ndarray]:
        """``(episodes, values (seeds, points))`` of ``column``; evaluation columns keep only
        the evaluated episodes."""
        values = self.metrics[column]
        keep = np.isfinite(values).all(axis=0)
        return self.episodes[keep], values[:, keep]

    def snapshots(self) -> list[Snapshot]:
        """Every snapshot, in episode order (read once)."""
        if self._snapshots is None:
            self._snapshots = (self.stored_snapshots() if self.stored_snapshots
                               else load_snapshot_dir(self.path))
        return self._snapshots

    def final_snapshot(self) -> Snapshot:
        snaps = self.snapshots()
        if not snaps:
            raise ExperimentError(f"{self.path} has no snapshot; run `hiddpg reproduce` on it")
        return snaps[-1]

    def progress(self) -> dict[str, Any]:
        """``episodes``, ``wall_time``, ``status`` (and ``error``) of the run."""
        return dict(self.info) if self.info is not None else Run.open(self.path).progress()


def load_run(path: str | Path) -> RunData:
    """A run directory's config and metrics.csv as arrays (seeds, episodes), or an artifact
    (a directory with ``meta.json``, :func:`hiddpg.experiments.artifacts.load_artifact`)."""
    from hiddpg.experiments.artifacts import is_artifact, load_artifact

    if is_artifact(path):
        return load_artifact(path)
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
    """Run directories among ``paths``: one itself (or an artifact), or every one below a
    directory (sorted; the artifacts below it where it holds no run directory)."""
    from hiddpg.experiments.artifacts import is_artifact

    found: list[Path] = []
    for p in map(Path, paths):
        if (p / CONFIG_FILE).is_file():
            found.append(p)
        elif p.is_dir():
            below = sorted(c.parent for c in p.rglob(CONFIG_FILE))
            runs = [b for b in below if not is_artifact(b)]
            found += runs or below
        else:
            raise ExperimentError(f"{p} is neither a run directory nor a directory of runs")
    return found

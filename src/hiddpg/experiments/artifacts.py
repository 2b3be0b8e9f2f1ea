"""Artifacts: a small, self-describing copy of what the figures read from one run.

``hiddpg reproduce`` writes one per run to ``OUT/artifacts/<algo>-<task>/``
(:func:`export_run`)::

    config.json      the run's config.json as it is (config, seeds, versions)
    meta.json        format, hiddpg version, algorithm, task, preset, seeds, episodes trained,
                     wall time, status, the machines that trained which episodes
                     (:mod:`hiddpg.machine`), the training block size, the columns and files
    evaluations.csv  seed, episode and every ``eval_*`` column of metrics.csv, on the
                     evaluated episodes only, every value as metrics.csv holds it
    training.csv     seed, episode (a block's last) and the block means of the training
                     columns the figures read (:class:`hiddpg.experiments.rundata.TrainingBlocks`)
    snapshots.json   every evaluation snapshot (:mod:`hiddpg.experiments.snapshots`)

No checkpoint and no per-episode training row: a run of 15 seeds and 3000 episodes takes a few
hundred KB. :func:`load_artifact` reads one back as a
:class:`~hiddpg.experiments.rundata.RunData` from which the figures compute the same numbers
as from the run directory; ``hiddpg report`` redraws the figures from them.
"""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path
from typing import Any

import numpy as np

from hiddpg.experiments.rundata import (
    TRAINING_BLOCKS,
    ExperimentError,
    RunData,
    TrainingBlocks,
    load_run,
)
from hiddpg.experiments.snapshots import POSITION_DIGITS, snapshots_from_json, snapshots_to_json
from hiddpg.runs import CONFIG_FILE, Run, atomic_write

ARTIFACTS_DIR = "artifacts"
ARTIFACT_FORMAT = "hiddpg-artifact/1"
META_FILE = "meta.json"
EVALUATIONS_FILE = "evaluations.csv"
TRAINING_FILE = "training.csv"
SNAPSHOTS_FILE = "snapshots.json"
PROGRESS_KEYS = ("episodes", "total_episodes", "wall_time", "status", "error", "machines")
"""The run's progress.json entries meta.json repeats."""


def is_artifact(path: str | Path) -> bool:
    return (Path(path) / META_FILE).is_file()


def package_version() -> str:
    from hiddpg import __version__

    return __version__


def export_run(run_dir: str | Path, dest: str | Path) -> Path:
    """Write the artifact of the run directory ``run_dir`` to ``dest`` (meta.json last, so a
    directory with it is whole); returns ``dest``."""
    run_dir = Path(run_dir)
    if is_artifact(run_dir):
        raise ExperimentError(f"{run_dir} is an artifact, not a run directory")
    data, progress = load_run(run_dir), Run.open(run_dir).progress()
    return write_artifact(data, (run_dir / CONFIG_FILE).read_bytes(), progress, dest)


def write_artifact(data: RunData, config_json: bytes, progress: dict[str, Any],
                   dest: str | Path, **extra: Any) -> Path:
    """Write ``data`` (a run read back), its config.json and its progress as the artifact
    ``dest``, meta.json last; ``extra`` entries are added to meta.json. Returns ``dest``."""
    dest = Path(dest)
    blocks, snaps = data.training, data.snapshots()
    evaluations = [c for c in data.metrics if c.startswith("eval_")]
    files = {CONFIG_FILE: config_json,
             EVALUATIONS_FILE: _evaluations_csv(data, evaluations),
             TRAINING_FILE: _training_csv(data.seeds, blocks),
             SNAPSHOTS_FILE: snapshots_to_json(snaps).encode()}
    meta = {"format": ARTIFACT_FORMAT, "hiddpg_version": package_version(),
            "algo": data.config.algo, "task": data.config.task, "preset": data.config.preset,
            "seeds": list(data.seeds),
            **{k: progress[k] for k in PROGRESS_KEYS if k in progress},
            "training_block": blocks.size,
            "training_block_rule": f"max(1, episodes // {TRAINING_BLOCKS}) episodes, counted "
                                   "back from the last; the first episodes % size left out",
            "training_columns": list(blocks.means), "evaluation_columns": evaluations,
            "snapshot_episodes": [s.episode for s in snaps],
            "snapshot_position_digits": POSITION_DIGITS,
            "files": {name: len(content) for name, content in files.items()}, **extra}
    dest.mkdir(parents=True, exist_ok=True)
    (dest / META_FILE).unlink(missing_ok=True)
    for name, content in files.items():
        atomic_write(dest / name, content)
    atomic_write(dest / META_FILE, (json.dumps(meta, indent=2) + "\n").encode())
    return dest


def _cell(x: float) -> str:
    """The shortest text that reads back to ``x`` (empty for NaN)."""
    return "" if np.isnan(x) else repr(float(x))


def _csv(header: list[str], rows: list[list[Any]]) -> bytes:
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(header)
    writer.writerows(rows)
    return buf.getvalue().encode()


def _evaluations_csv(data: RunData, columns: list[str]) -> bytes:
    values = np.stack([data.metrics[c] for c in columns], axis=2) if columns else None
    rows = []
    if values is not None:
        evaluated = np.flatnonzero(np.isfinite(values).any(axis=(0, 2)))
        for i, seed in enumerate(data.seeds):
            rows += [[seed, int(data.episodes[j]), *map(_cell, values[i, j])]
                     for j in evaluated]
    return _csv(["seed", "episode", *columns], rows)


def _training_csv(seeds: tuple[int, ...], blocks: TrainingBlocks) -> bytes:
    columns = list(blocks.means)
    rows = [[seed, int(end), *(_cell(blocks.means[c][i, k]) for c in columns)]
            for i, seed in enumerate(seeds) for k, end in enumerate(blocks.ends)]
    return _csv(["seed", "episode", *columns], rows)


# ------------------------------------------------------------------------------------ read


def read_meta(path: str | Path) -> dict[str, Any]:
    """An artifact's meta.json, checked; :class:`ExperimentError` (one line) if it is not one
    this version reads."""
    file = Path(path) / META_FILE
    try:
        meta = json.loads(file.read_text())
    except FileNotFoundError:
        raise ExperimentError(f"{path} is not an artifact (no {META_FILE})") from None
    except (ValueError, UnicodeDecodeError) as err:
        raise ExperimentError(f"{file} is not valid JSON ({err})") from None
    if not isinstance(meta, dict) or meta.get("format") != ARTIFACT_FORMAT:
        found = meta.get("format") if isinstance(meta, dict) else None
        raise ExperimentError(f"{file} has format {found!r}, not {ARTIFACT_FORMAT!r}")
    return meta


def load_artifact(path: str | Path) -> RunData:
    """The artifact at ``path`` as a :class:`RunData`: evaluation columns at the evaluated
    episodes, the stored training blocks and snapshots, meta.json's progress."""
    path = Path(path)
    meta = read_meta(path)
    run = Run.open(path)
    try:
        episodes, metrics = _read_table(path / EVALUATIONS_FILE, run.seeds)
        ends, means = _read_table(path / TRAINING_FILE, run.seeds)
    except (FileNotFoundError, KeyError, ValueError) as err:
        raise ExperimentError(f"{path} is not a whole artifact ({err})") from None
    blocks = TrainingBlocks(int(meta["training_block"]), ends, means)
    info = {k: meta[k] for k in PROGRESS_KEYS if k in meta}

    def snapshots():
        try:
            return snapshots_from_json((path / SNAPSHOTS_FILE).read_text())
        except (FileNotFoundError, KeyError, ValueError) as err:
            raise ExperimentError(f"{path / SNAPSHOTS_FILE} cannot be read ({err})") from None

    return RunData(path, run.config, run.seeds, episodes, metrics, blocks, snapshots, info)


def _read_table(file: Path, seeds: tuple[int, ...]) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """A ``seed, episode, columns...`` CSV as (episodes,) and column -> (seeds, episodes)."""
    with open(file, newline="") as f:
        reader = csv.reader(f)
        header = next(reader)
        rows = list(reader)
    if header[:2] != ["seed", "episode"]:
        raise ValueError(f"{file.name} does not start with seed, episode")
    episodes = np.array(sorted({int(r[1]) for r in rows}), dtype=int)
    where = {e: j for j, e in enumerate(episodes)}
    index = {s: i for i, s in enumerate(seeds)}
    table = np.full((len(seeds), len(episodes), len(header) - 2), np.nan)
    for r in rows:
        table[index[int(r[0])], where[int(r[1])]] = [float(x) if x else np.nan for x in r[2:]]
    return episodes, {c: table[:, :, k] for k, c in enumerate(header[2:])}

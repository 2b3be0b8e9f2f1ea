"""The run directory: config, metrics, TensorBoard events, checkpoints and resume.

A run lives in ``runs/<name>/`` (name default ``<algo>-<task>-<timestamp>``)::

    config.json              the TrainConfig (configs.to_dict), the seeds, hiddpg/jax versions,
                             and a user's task registration (to register it again on resume)
    metrics.csv              one row per seed per training episode (see METRIC_COLUMNS)
    checkpoint.msgpack       the whole vmapped RunState (flax msgpack), after every chunk
    checkpoint.prev.msgpack  the checkpoint before it, kept in case the last one is damaged
    progress.json            episodes done, wall time, status: running / finished / failed /
                             interrupted (Ctrl-C or SIGTERM, with the signal's name), and
                             which machine trained which episodes (:mod:`hiddpg.machine`)
    writer.lock              held by the one process training the run (its pid, host, since)
    tb/seed_<s>/             TensorBoard event files (only if tensorboardX is installed)

Checkpoint and progress are written atomically (:func:`hiddpg.run_files.atomic_write`), so a
crash leaves the previous complete file. Metrics rows are appended before the checkpoint is
written; rows past the checkpoint's episode count (a crash in between) are dropped by
:meth:`Run.truncate_metrics` on resume, so a resumed run writes no row twice. Before a run
is continued every file is checked (:mod:`hiddpg.run_check`). This module is shell: it does
I/O and calls the core only through :class:`hiddpg.train.Trainer`.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import jax
import numpy as np
from flax import serialization

from hiddpg.configs import TrainConfig, from_dict, to_dict
from hiddpg.envs.registry import BUILTIN_TASKS, TASKS, restore_task
from hiddpg.host.task import gym_task, is_gym_task, restore_gym_task
from hiddpg.machine import describe, extend_spans
from hiddpg.run_check import (
    CONFIG_REMEDY,
    load_state,
    raw_episodes,
    read_meta,
    read_raw,
    scan_metrics,
)
from hiddpg.run_files import FILE_MODE as FILE_MODE  # re-exported for run-file writers
from hiddpg.run_files import LOCK_FILE, RunFileError, WriterLock, atomic_write
from hiddpg.run_tb import TensorBoardLog
from hiddpg.stopping import writing
from hiddpg.train import RunState, Trainer, seed_keys
from hiddpg.train import make_trainer as make_trainer  # re-exported: the runs' trainers

CONFIG_FILE = "config.json"
METRICS_FILE = "metrics.csv"
CHECKPOINT_FILE = "checkpoint.msgpack"
PREVIOUS_CHECKPOINT_FILE = "checkpoint.prev.msgpack"
PROGRESS_FILE = "progress.json"
TB_DIR = "tb"
#: the fixed leading columns of metrics.csv; sorted extra metrics follow.
METRIC_COLUMNS = ("seed", "episode", "env_steps", "return", "env_return", "length", "switches",
                  "eval_return")


def default_name(algo: str, task: str) -> str:
    """``<algo>-<task>-<YYYYmmdd-HHMMSS>``."""
    return f"{algo}-{task}-{time.strftime('%Y%m%d-%H%M%S')}"


def _json_bytes(obj: Any) -> bytes:
    return (json.dumps(obj, indent=2) + "\n").encode()


def _cell(value: Any) -> str:
    """One CSV cell: ints as ints, floats with 9 significant digits (float32 round trip)."""
    if isinstance(value, str):
        return value
    v = np.asarray(value).item()
    if isinstance(v, bool):
        return str(int(v))
    if isinstance(v, int):
        return str(v)
    return format(v, ".9g") if math.isfinite(v) else str(v)


@dataclass
class Run:
    """An open run directory."""

    path: Path
    config: TrainConfig
    seeds: tuple[int, ...]
    header: list[str] | None = None
    lock: WriterLock | None = None
    notes: list[str] = field(default_factory=list)
    """What opening the run recovered (:func:`hiddpg.runner.open_for_resume`), to report."""
    _steps: dict[int, int] = field(default_factory=dict)
    _tb: TensorBoardLog | None = None

    # -- creating and opening -----------------------------------------------------------------
    @classmethod
    def create(cls, path: str | Path, config: TrainConfig, seeds: list[int] | tuple[int, ...]
               ) -> Run:
        """Make a new run directory (it must not exist yet) holding config.json and
        progress.json, atomically: it is written under a hidden temporary name and renamed,
        so a crash never leaves a half-made run. The returned run holds its writer lock."""
        import hiddpg

        path = Path(path)
        if path.exists():
            raise FileExistsError(f"run directory {path} exists")
        path.parent.mkdir(parents=True, exist_ok=True)
        meta = {"config": to_dict(config), "seeds": [int(s) for s in seeds],
                "versions": {"hiddpg": hiddpg.__version__, "jax": jax.__version__,
                             "python": sys.version.split()[0]},
                "created": time.strftime("%Y-%m-%dT%H:%M:%S")}
        if config.task not in BUILTIN_TASKS and config.task in TASKS:  # a user's task
            meta["task"] = TASKS[config.task].declaration()
        elif is_gym_task(config.task):  # a Gymnasium task's declaration (hiddpg.host)
            meta["gym_task"] = gym_task(config.task).declaration()
        with writing():
            tmp = Path(tempfile.mkdtemp(dir=path.parent, prefix=f".{path.name}.",
                                        suffix=".creating"))
            lock = WriterLock(tmp)
            lock.acquire()
            run = cls(tmp, config, tuple(int(s) for s in seeds), lock=lock)
            atomic_write(tmp / CONFIG_FILE, _json_bytes(meta))
            run.write_progress(0, 0.0, "running")
            os.chmod(tmp, 0o755)
            os.rename(tmp, path)
            run.path, lock.path = path, path / LOCK_FILE
        return run

    @classmethod
    def open(cls, path: str | Path) -> Run:
        """Open an existing run directory: config.json checked and parsed (a
        :class:`RunFileError` names what is wrong), the metrics.csv header read if present."""
        path = Path(path)
        if not path.is_dir():
            raise FileNotFoundError(f"{path} is not a run directory (no such directory)")
        if not (path / CONFIG_FILE).is_file():
            raise FileNotFoundError(f"{path} is not a run directory (no {CONFIG_FILE})")
        meta = read_meta(path / CONFIG_FILE)
        try:  # a user's task is registered again; if that fails, using it says it is unknown
            restore_task(meta.get("task"))
            config = meta.get("config")
            restore_gym_task(config.get("task") if isinstance(config, dict) else None,
                             meta.get("gym_task"))
        except ValueError:
            pass
        try:
            config = from_dict(meta["config"])
            seeds = tuple(int(s) for s in meta["seeds"])
            if not isinstance(config, TrainConfig):
                raise TypeError(f"'config' is a {type(config).__name__}, not a TrainConfig")
        except (ValueError, TypeError, KeyError) as err:
            raise RunFileError(path / CONFIG_FILE, f"does not hold a valid run config ({err})",
                               CONFIG_REMEDY) from None
        run = cls(path, config, seeds)
        if (path / METRICS_FILE).is_file():
            with open(path / METRICS_FILE, newline="") as f:
                run.header = next(csv.reader(f), None)
        return run

    def acquire(self) -> None:
        """Become the run directory's only writer (:class:`hiddpg.run_files.WriterLock`);
        raises :class:`hiddpg.run_files.RunLockedError` naming a live holder."""
        if self.lock is None:
            self.lock = WriterLock(self.path)
        if self.lock.held:
            return
        self.lock.acquire()
        if self.lock.took_over:
            self.notes.append(f"took over the writer lock left by {self.lock.took_over}, "
                              "which has ended")

    def release(self) -> None:
        if self.lock is not None:
            self.lock.release()

    def update_config(self, config: TrainConfig) -> None:
        """Rewrite config.json with a changed config (``--resume --episodes N``)."""
        meta = json.loads((self.path / CONFIG_FILE).read_text())
        meta["config"] = to_dict(config)
        atomic_write(self.path / CONFIG_FILE, _json_bytes(meta))
        self.config = config

    # -- progress -----------------------------------------------------------------------------
    def write_progress(self, episodes: int, wall_time: float, status: str, **extra: Any) -> None:
        """progress.json: ``episodes`` trained in ``wall_time`` seconds, the run's ``status``,
        ``extra`` entries, and the machines that trained it (:mod:`hiddpg.machine`)."""
        try:
            previous = self.progress()
        except RunFileError:  # a new run, or a progress.json being rewritten from the checkpoint
            previous = None
        data = {"episodes": int(episodes), "total_episodes": self.config.episodes,
                "wall_time": round(float(wall_time), 3), "status": status, **extra,
                "machines": extend_spans(previous, int(episodes), wall_time, describe())}
        atomic_write(self.path / PROGRESS_FILE, _json_bytes(data))

    def progress(self) -> dict[str, Any]:
        """progress.json; :class:`RunFileError` if it is missing or not valid JSON."""
        path = self.path / PROGRESS_FILE
        try:
            data = json.loads(path.read_text())
            if isinstance(data, dict) and {"episodes", "wall_time", "status"} <= set(data):
                return data
            problem = "lacks episodes, wall_time or status"
        except FileNotFoundError:
            problem = "is missing"
        except (ValueError, UnicodeDecodeError) as err:
            problem = f"is not valid JSON ({err})"
        raise RunFileError(path, problem, "resuming the run rewrites it from the checkpoint")

    # -- checkpoints --------------------------------------------------------------------------
    @property
    def checkpoint_path(self) -> Path:
        return self.path / CHECKPOINT_FILE

    @property
    def previous_checkpoint_path(self) -> Path:
        return self.path / PREVIOUS_CHECKPOINT_FILE

    def save_checkpoint(self, state: RunState) -> None:
        """Serialise the vmapped run state (flax msgpack), atomically, keeping the checkpoint
        it replaces as checkpoint.prev.msgpack."""
        data = serialization.to_bytes(jax.device_get(state))
        with writing():
            if self.checkpoint_path.is_file():
                os.replace(self.checkpoint_path, self.previous_checkpoint_path)
            atomic_write(self.checkpoint_path, data)

    def initial_state(self, trainer: Trainer) -> RunState:
        return trainer.init_seeds(seed_keys(self.seeds))

    def state_shapes(self, trainer: Trainer) -> Any:
        """The structure of this run's state (``jax.eval_shape``; nothing is compiled)."""
        return jax.eval_shape(trainer.init_seeds, seed_keys(self.seeds))

    def checkpoint_episodes(self) -> int:
        """Episodes done in the checkpoint, read without building a trainer (0 if none);
        :class:`RunFileError` if it is not a checkpoint."""
        if not self.checkpoint_path.is_file():
            return 0
        return raw_episodes(read_raw(self.checkpoint_path))

    def load_checkpoint(self, trainer: Trainer) -> tuple[RunState, int]:
        """The checkpointed state, checked against ``trainer``'s state structure, and its
        episodes done; a fresh state and 0 if no checkpoint was written yet. Raises
        :class:`RunFileError` naming the file and what is wrong."""
        if not self.checkpoint_path.is_file():
            return self.initial_state(trainer), 0
        return load_state(self.checkpoint_path, self.state_shapes(trainer))

    # -- metrics ------------------------------------------------------------------------------
    @property
    def metrics_path(self) -> Path:
        return self.path / METRICS_FILE

    def truncate_metrics(self, episodes: int) -> int:
        """Drop rows past ``episodes`` (written before a crash, after the last checkpoint) and
        remember each seed's env steps; returns the number of rows dropped."""
        self._steps = {s: 0 for s in self.seeds}
        if not self.metrics_path.is_file():
            return 0
        text = self.metrics_path.read_text()
        lines = text.splitlines(keepends=True)
        if not lines:
            return 0
        self.header = next(csv.reader([lines[0]]))
        col_seed, col_ep = self.header.index("seed"), self.header.index("episode")
        col_steps = self.header.index("env_steps")
        keep = [lines[0]]
        for line in lines[1:]:
            row = next(csv.reader([line]))
            if len(row) != len(self.header) or not line.endswith("\n"):
                continue  # a torn last line
            if int(row[col_ep]) <= episodes:
                keep.append(line)
                self._steps[int(row[col_seed])] = int(row[col_steps])
        dropped = len(lines) - len(keep)
        if dropped:
            atomic_write(self.metrics_path, "".join(keep).encode())
        return dropped

    def append_metrics(self, train: dict[str, np.ndarray], evals: dict[str, np.ndarray]) -> None:
        """Append one chunk: ``train`` arrays are (seeds, episodes), ``evals`` (seeds, evals);
        rows are ordered by episode, then seed."""
        train = {k: np.asarray(v) for k, v in train.items()}
        evals = {k: np.asarray(v) for k, v in evals.items()}
        if self.header is None:
            extra = [k for k in train if k not in METRIC_COLUMNS and k != "episode"]
            extra += [f"eval_{k}" for k in evals
                      if k != "episode" and f"eval_{k}" not in METRIC_COLUMNS]
            self.header = list(METRIC_COLUMNS) + sorted(set(extra))
        if not self._steps:
            self._steps = {s: 0 for s in self.seeds}
        buf = io.StringIO()
        writer = csv.writer(buf, lineterminator="\n")
        new_file = not self.metrics_path.is_file() or self.metrics_path.stat().st_size == 0
        if new_file:
            writer.writerow(self.header)
        n_seeds, n_eps = train["episode"].shape
        for e in range(n_eps):
            for i, seed in enumerate(self.seeds[:n_seeds]):
                writer.writerow(self._row(seed, i, e, train, evals))
        with writing(), open(self.metrics_path, "a", newline="") as f:
            f.write(buf.getvalue())
            f.flush()
            os.fsync(f.fileno())

    def _row(self, seed: int, i: int, e: int, train: dict, evals: dict) -> list[str]:
        episode = int(train["episode"][i, e])
        steps = train["env_steps"][i, e] if "env_steps" in train else None
        self._steps[seed] = (int(steps) if steps is not None
                             else self._steps.get(seed, 0) + int(train["length"][i, e]))
        values: dict[str, Any] = {k: v[i, e] for k, v in train.items()}
        values.update(seed=seed, episode=episode, env_steps=self._steps[seed])
        hit = np.flatnonzero(evals["episode"][i] == episode) if "episode" in evals else []
        if len(hit):
            values.update({f"eval_{k}": v[i, hit[0]] for k, v in evals.items() if k != "episode"})
        return [_cell(values[c]) if c in values else "" for c in self.header]

    def read_metrics(self) -> list[dict[str, str]]:
        """metrics.csv's rows, after :func:`hiddpg.run_check.scan_metrics` found every seed's
        episodes complete and in order (a :class:`RunFileError` otherwise)."""
        if not self.metrics_path.is_file():
            return []
        scan_metrics(self.metrics_path, self.seeds)
        with open(self.metrics_path, newline="") as f:
            return list(csv.DictReader(f))

    def final_eval(self) -> dict[int, float]:
        """Each seed's last evaluation return recorded in metrics.csv."""
        out: dict[int, float] = {}
        for row in self.read_metrics():
            if row.get("eval_return"):
                out[int(row["seed"])] = float(row["eval_return"])
        return out

    # -- TensorBoard --------------------------------------------------------------------------
    def write_tensorboard(self, train: dict[str, np.ndarray], evals: dict[str, np.ndarray]
                          ) -> None:
        """Scalars under ``train/<key>`` and ``eval/<key>`` in ``tb/seed_<s>/``
        (:class:`hiddpg.run_tb.TensorBoardLog`)."""
        if self._tb is None:
            self._tb = TensorBoardLog(self.path / TB_DIR, self.seeds)
        with writing():
            self._tb.write(train, evals)

    def close(self) -> None:
        """Close the TensorBoard writers and give up the writer lock."""
        if self._tb is not None:
            self._tb.close()
        self._tb = None
        self.release()

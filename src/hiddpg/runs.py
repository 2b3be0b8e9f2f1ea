"""The run directory: config, metrics, TensorBoard events, checkpoints and resume.

A run lives in ``runs/<name>/`` (name default ``<algo>-<task>-<timestamp>``)::

    config.json         the TrainConfig (configs.to_dict), the seeds, hiddpg/jax versions,
                        and a user's task registration (to register it again on resume)
    metrics.csv         one row per seed per training episode (see METRIC_COLUMNS)
    checkpoint.msgpack  the whole vmapped RunState (flax msgpack), rewritten after every chunk
    progress.json       episodes done, wall time, status: running / finished / failed /
                        interrupted (Ctrl-C or SIGTERM; resumable like a failed run)
    tb/seed_<s>/        TensorBoard event files (only if tensorboardX is installed)

Checkpoint and progress are written atomically (temporary file in the same directory, fsync,
``os.replace``), so a crash leaves the previous complete file. Metrics rows are appended before
the checkpoint is written; rows past the checkpoint's episode count (a crash in between) are
dropped by :meth:`Run.truncate_metrics` on resume, so a resumed run writes no row twice.
This module is shell: it does I/O and calls the core only through :class:`hiddpg.train.Trainer`.
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
from hiddpg.train import RunState, Trainer, seed_keys

CONFIG_FILE = "config.json"
METRICS_FILE = "metrics.csv"
CHECKPOINT_FILE = "checkpoint.msgpack"
PROGRESS_FILE = "progress.json"
TB_DIR = "tb"
FILE_MODE = 0o644
#: the fixed leading columns of metrics.csv; sorted extra metrics follow.
METRIC_COLUMNS = ("seed", "episode", "env_steps", "return", "env_return", "length", "switches",
                  "eval_return")


def default_name(algo: str, task: str) -> str:
    """``<algo>-<task>-<YYYYmmdd-HHMMSS>``."""
    return f"{algo}-{task}-{time.strftime('%Y%m%d-%H%M%S')}"


def atomic_write(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` via a temporary file in the same directory, fsync, replace."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            os.fchmod(f.fileno(), FILE_MODE)
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def _json_bytes(obj: Any) -> bytes:
    return (json.dumps(obj, indent=2) + "\n").encode()


_TRAINERS: dict[TrainConfig, Trainer] = {}


def make_trainer(config: TrainConfig) -> Trainer:
    """A :class:`Trainer` for ``config``, shared by equal configs in this process so that its
    jitted functions compile once (the jit cache is keyed by the trainer object)."""
    try:
        hash(config)
    except TypeError:  # an unhashable env override value
        return Trainer(config)
    if config not in _TRAINERS:
        _TRAINERS[config] = Trainer(config)
    return _TRAINERS[config]


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
    _steps: dict[int, int] = field(default_factory=dict)
    _tb: dict[int, Any] | None = None

    # -- creating and opening -----------------------------------------------------------------
    @classmethod
    def create(cls, path: str | Path, config: TrainConfig, seeds: list[int] | tuple[int, ...]
               ) -> Run:
        """Make a new run directory (it must not exist yet) and write config.json."""
        import hiddpg

        path = Path(path)
        path.mkdir(parents=True, exist_ok=False)
        meta = {"config": to_dict(config), "seeds": [int(s) for s in seeds],
                "versions": {"hiddpg": hiddpg.__version__, "jax": jax.__version__,
                             "python": sys.version.split()[0]},
                "created": time.strftime("%Y-%m-%dT%H:%M:%S")}
        if config.task not in BUILTIN_TASKS and config.task in TASKS:  # a user's task
            meta["task"] = TASKS[config.task].declaration()
        atomic_write(path / CONFIG_FILE, _json_bytes(meta))
        run = cls(path, config, tuple(int(s) for s in seeds))
        run.write_progress(0, 0.0, "running")
        return run

    @classmethod
    def open(cls, path: str | Path) -> Run:
        """Open an existing run directory (config.json and, if present, metrics.csv header)."""
        path = Path(path)
        if not (path / CONFIG_FILE).is_file():
            raise FileNotFoundError(f"{path} is not a run directory (no {CONFIG_FILE})")
        meta = json.loads((path / CONFIG_FILE).read_text())
        try:  # a user's task is registered again; if that fails, using it says it is unknown
            restore_task(meta.get("task"))
        except ValueError:
            pass
        run = cls(path, from_dict(meta["config"]), tuple(meta["seeds"]))
        if (path / METRICS_FILE).is_file():
            with open(path / METRICS_FILE, newline="") as f:
                run.header = next(csv.reader(f), None)
        return run

    def update_config(self, config: TrainConfig) -> None:
        """Rewrite config.json with a changed config (``--resume --episodes N``)."""
        meta = json.loads((self.path / CONFIG_FILE).read_text())
        meta["config"] = to_dict(config)
        atomic_write(self.path / CONFIG_FILE, _json_bytes(meta))
        self.config = config

    # -- progress -----------------------------------------------------------------------------
    def write_progress(self, episodes: int, wall_time: float, status: str, **extra: Any) -> None:
        data = {"episodes": int(episodes), "total_episodes": self.config.episodes,
                "wall_time": round(float(wall_time), 3), "status": status, **extra}
        atomic_write(self.path / PROGRESS_FILE, _json_bytes(data))

    def progress(self) -> dict[str, Any]:
        return json.loads((self.path / PROGRESS_FILE).read_text())

    # -- checkpoints --------------------------------------------------------------------------
    @property
    def checkpoint_path(self) -> Path:
        return self.path / CHECKPOINT_FILE

    def save_checkpoint(self, state: RunState) -> None:
        """Serialise the vmapped run state (flax msgpack), atomically."""
        atomic_write(self.checkpoint_path, serialization.to_bytes(jax.device_get(state)))

    def initial_state(self, trainer: Trainer) -> RunState:
        return trainer.init_seeds(seed_keys(self.seeds))

    def checkpoint_episodes(self) -> int:
        """Episodes done in the checkpoint, read without building a trainer (0 if none)."""
        if not self.checkpoint_path.is_file():
            return 0
        raw = serialization.msgpack_restore(self.checkpoint_path.read_bytes())
        return int(np.asarray(raw["episode"]).flat[0])

    def load_checkpoint(self, trainer: Trainer) -> tuple[RunState, int]:
        """The checkpointed state (structure from ``init_seeds``) and its episodes done; a
        fresh state and 0 if no checkpoint was written yet."""
        template = self.initial_state(trainer)
        if not self.checkpoint_path.is_file():
            return template, 0
        state = serialization.from_bytes(template, self.checkpoint_path.read_bytes())
        state = jax.tree.map(jax.numpy.asarray, state)
        done = np.asarray(state.episode)
        if not (done == done.flat[0]).all():
            raise ValueError(f"checkpoint seeds are at different episodes: {done.tolist()}")
        return state, int(done.flat[0])

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
        with open(self.metrics_path, "a", newline="") as f:
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
        if not self.metrics_path.is_file():
            return []
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
        """Scalars under ``train/<key>`` and ``eval/<key>`` in ``tb/seed_<s>/`` (skipped, with
        one warning, if tensorboardX is not installed)."""
        if self._tb is None:
            self._tb = _open_writers(self.path / TB_DIR, self.seeds)
        if not self._tb:
            return
        for i, seed in enumerate(self.seeds):
            w = self._tb[seed]
            for e, ep in enumerate(np.asarray(train["episode"][i])):
                for k, v in train.items():
                    if k != "episode":
                        w.add_scalar(f"train/{k}", float(np.asarray(v)[i, e]), int(ep))
            for e, ep in enumerate(np.asarray(evals["episode"][i])):
                for k, v in evals.items():
                    if k != "episode":
                        w.add_scalar(f"eval/{k}", float(np.asarray(v)[i, e]), int(ep))
            w.flush()

    def close(self) -> None:
        for w in (self._tb or {}).values():
            w.close()
        self._tb = None


def _open_writers(root: Path, seeds: tuple[int, ...]) -> dict[int, Any]:
    try:
        from tensorboardX import SummaryWriter
    except ImportError:
        print("warning: tensorboardX is not installed; skipping TensorBoard logs "
              "(pip install 'hiddpg[tb]')", file=sys.stderr)
        return {}
    return {s: SummaryWriter(logdir=str(root / f"seed_{s}")) for s in seeds}


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

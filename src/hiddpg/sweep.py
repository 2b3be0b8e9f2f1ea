"""Sweeps as run directories: each configuration of a spec is one ``OUT/<name>``, created,
resumed or skipped, with the sweep's manifest and attempt records beside them.

Every configuration is one run directory ``OUT/<name>``, exactly what ``hiddpg train`` writes,
its seeds vmapped in one process; the spec, its expansion and the names are
:mod:`hiddpg.sweep_spec` (re-exported here). A run is complete when its progress.json says
``finished``. Shell: I/O around :mod:`hiddpg.runner` and :mod:`hiddpg.runs`.
"""

from __future__ import annotations

import json
import shutil
import socket
import time
from pathlib import Path

from hiddpg import runner
from hiddpg.host.declare import record_sources
from hiddpg.host.task import is_gym_task
from hiddpg.run_files import RunFileError
from hiddpg.runs import CONFIG_FILE, PROGRESS_FILE, Run, atomic_write, make_trainer
from hiddpg.sweep_spec import (
    DEFAULT_PRESET,
    DEFAULT_SEEDS,
    HASH_DIGITS,
    LABEL_MAX_CHARS,
    MAX_ERRORS_SHOWN,
    REPLACED_KEYS,
    SPEC_KEYS,
    SweepError,
    SweepRun,
    config_hash,
    expand,
    grid_table,
    load_spec,
    run_name,
    set_list,
)

__all__ = [
    "DEFAULT_PRESET", "DEFAULT_SEEDS", "FINISHED", "HASH_DIGITS", "LABEL_MAX_CHARS",
    "MANIFEST_FILE", "MAX_ERRORS_SHOWN", "NEW", "REPLACED_KEYS", "RESUME", "SPEC_KEYS",
    "SWEEP_DIR", "SweepError", "SweepRun", "config_hash", "expand", "find_runs", "grid_table",
    "is_finished", "load_spec", "open_run", "prepare", "record_attempt", "run_name",
    "run_state", "set_list", "write_manifest",
]

MANIFEST_FILE = "sweep.json"
#: sweep bookkeeping under OUT: attempts/<name>.json (host, pid, start episode), logs/
SWEEP_DIR = ".sweep"
NEW, RESUME, FINISHED = "new", "resume", "finished"


# -- state ------------------------------------------------------------------------------------
def is_finished(path: str | Path, episodes: int = 0) -> bool:
    """Whether the run directory's progress.json says ``finished`` (with at least
    ``episodes`` episodes done)."""
    try:
        progress = json.loads((Path(path) / PROGRESS_FILE).read_text())
    except (FileNotFoundError, UnicodeDecodeError, json.JSONDecodeError):
        return False
    if not isinstance(progress, dict):
        return False
    return progress.get("status") == "finished" and progress.get("episodes", 0) >= episodes


def run_state(out: Path, run: SweepRun) -> str:
    """``new`` (no run directory yet), ``resume`` or ``finished``; raises :class:`SweepError`
    if the directory holds another config or other seeds."""
    path = out / run.name
    if not path.exists():
        return NEW
    if not (path / CONFIG_FILE).is_file():
        if [p for p in path.iterdir() if not p.name.startswith(".")]:
            raise SweepError(f"{path} exists but is not a run directory (no {CONFIG_FILE}); "
                             "remove it or choose another --out")
        return NEW  # only hidden files: nothing of a run
    try:
        saved = Run.open(path)
    except RunFileError as err:
        raise SweepError(str(err)) from None
    if config_hash(saved.config) != config_hash(run.config):  # JSON-level: lists == tuples
        raise SweepError(f"{path}/{CONFIG_FILE} holds another config than the spec gives for "
                         f"{run.describe()} (was the code changed?); remove it or choose "
                         "another --out")
    if saved.seeds != run.seeds:
        raise SweepError(f"{path} was trained on seeds {list(saved.seeds)}, the spec asks for "
                         f"{list(run.seeds)}; choose another --out")
    if is_finished(path, run.config.episodes):
        return FINISHED
    return RESUME


def prepare(run: SweepRun, out: Path) -> tuple[list[str] | None, int]:
    """``hiddpg train`` arguments that create or resume the run (``None`` if it is finished)
    and the episode it starts from."""
    state, start = _make_ready(run, out)
    if state == FINISHED:
        return None, start
    if state == NEW:
        return run.train_argv(out), start
    return ["--resume", str(out / run.name)], start


def open_run(run: SweepRun, out: Path) -> runner.ReadyRun | None:
    """``run``'s directory under ``out``, created or opened for resume, with its trainer and
    the episode it starts from (:mod:`hiddpg.runner`); ``None`` if it is finished."""
    state, _ = _make_ready(run, out)
    if state == FINISHED:
        return None
    path = out / run.name
    run.declare()
    if state == NEW:
        trainer = make_trainer(run.config)
        ready = runner.ReadyRun(runner.prepare_new(run.config, run.seeds, path), trainer, 0)
        if is_gym_task(run.config.task):  # where its values came from, as hiddpg train says
            record_sources(path, run.config, trainer.env)
        return ready
    return runner.open_for_resume(path)


def _make_ready(run: SweepRun, out: Path) -> tuple[str, int]:
    """The run's state (:func:`run_state`) and the episode it starts from, after removing a
    directory without a run in it where a new run goes."""
    path = out / run.name
    state = run_state(out, run)
    if state == FINISHED:
        return state, run.config.episodes
    if state == NEW:
        if path.exists():
            shutil.rmtree(path)
        return state, 0
    try:
        return state, Run.open(path).checkpoint_episodes()
    except (RunFileError, FileNotFoundError):  # resuming checks the files and says what is wrong
        return state, 0


def record_attempt(out: Path, run: SweepRun, pid: int, start_episode: int) -> None:
    """Append ``{host, pid, start_episode, time}`` to ``OUT/.sweep/attempts/<name>.json``."""
    path = out / SWEEP_DIR / "attempts" / f"{run.name}.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    attempts = json.loads(path.read_text()) if path.is_file() else []
    attempts.append({"host": socket.gethostname(), "pid": pid, "start_episode": start_episode,
                     "time": time.strftime("%Y-%m-%dT%H:%M:%S")})
    atomic_write(path, (json.dumps(attempts, indent=2) + "\n").encode())


def write_manifest(out: Path, runs: list[SweepRun]) -> None:
    """``OUT/sweep.json``: every run this directory was asked for (merged over invocations),
    with its algorithm, task, preset, seeds, overrides and grid point."""
    path = out / MANIFEST_FILE
    entries = json.loads(path.read_text())["runs"] if path.is_file() else {}
    for run in runs:
        entries[run.name] = {"algo": run.algo, "task": run.task, "preset": run.preset,
                             "seeds": list(run.seeds), "sets": list(run.sets),
                             "grid": dict(run.grid), **run.declaration()}
    atomic_write(path, (json.dumps({"runs": entries}, indent=2) + "\n").encode())


def find_runs(root: str | Path) -> list[Path]:
    """Every run directory (one with a config.json) under ``root``, ``root`` itself if it is
    one; sweep outputs and nested sweeps are searched recursively, hidden directories are
    skipped, run directories are not entered. Sorted by path."""
    root = Path(root)
    found: list[Path] = []
    seen: set[Path] = set()

    def visit(d: Path) -> None:
        real = d.resolve()
        if real in seen:
            return
        seen.add(real)
        if (d / CONFIG_FILE).is_file():
            found.append(d)
            return
        for child in sorted(d.iterdir()):
            if child.is_dir() and not child.name.startswith("."):
                visit(child)

    if root.is_dir():
        visit(root)
    return sorted(found)

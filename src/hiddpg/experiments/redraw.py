"""The figures and the report redrawn from an output directory's artifacts, nothing trained.

``hiddpg reproduce`` records what it was asked for (scale, variant and its description,
overrides) in ``OUT/artifacts/reproduce.json`` (:func:`write_context`); :func:`artifact_context`
reads it back as a :class:`~hiddpg.experiments.common.Context` that draws from
``OUT/artifacts`` only, and :func:`drawable` says which figures have the artifacts they read.
"""

from __future__ import annotations

import json
from pathlib import Path

from hiddpg.experiments.artifacts import ARTIFACTS_DIR, is_artifact, package_version
from hiddpg.experiments.common import Context
from hiddpg.experiments.rundata import ExperimentError
from hiddpg.runs import atomic_write

CONTEXT_FILE = "reproduce.json"


def write_context(ctx: Context) -> Path:
    """Record ``ctx`` in ``ctx.out/artifacts/reproduce.json``."""
    data = {"scale": ctx.scale, "variant": ctx.variant, "described": ctx.describe(),
            "seeds": ctx.seeds, "episodes": ctx.episodes, "sets": list(ctx.sets),
            "tasks": list(ctx.tasks) if ctx.tasks else None, "hiddpg_version": package_version()}
    path = ctx.out / ARTIFACTS_DIR / CONTEXT_FILE
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(path, (json.dumps(data, indent=2) + "\n").encode())
    return path


def artifact_context(out: str | Path) -> Context:
    """The context recorded under ``out/artifacts``, drawing from the artifacts; Figs. 4-5 keep
    the recorded trajectory tasks that have an artifact. :class:`ExperimentError` (one line)
    for a missing directory, context or artifact."""
    from hiddpg.experiments.trajectory import ALGO, TASKS

    out = Path(out)
    folder = out / ARTIFACTS_DIR
    if not out.is_dir():
        raise ExperimentError(f"{out} is not a directory")
    if not folder.is_dir() or not any(is_artifact(p) for p in folder.iterdir()):
        raise ExperimentError(f"{folder} holds no artifact; `hiddpg reproduce --out {out}` "
                              "writes them")
    try:
        data = json.loads((folder / CONTEXT_FILE).read_text())
        ctx = Context(out, scale=data["scale"], variant=data["variant"], seeds=data["seeds"],
                      episodes=data["episodes"], sets=tuple(data["sets"]),
                      from_artifacts=True, described=data.get("described"))
    except FileNotFoundError:
        raise ExperimentError(f"{folder / CONTEXT_FILE} is missing; `hiddpg reproduce --out "
                              f"{out}` writes it") from None
    except (ValueError, KeyError, TypeError) as err:
        raise ExperimentError(f"{folder / CONTEXT_FILE} is not a reproduce context "
                              f"({type(err).__name__}: {err})") from None
    recorded = tuple(data.get("tasks") or TASKS)
    present = tuple(t for t in recorded if is_artifact(ctx.artifact_path(ALGO, t)))
    ctx.tasks, ctx.planned_tasks = present or recorded, recorded
    return ctx


def drawable(ctx: Context) -> dict[str, str | None]:
    """Figure -> ``None`` if the artifacts it reads are under ``ctx.out``, else what is
    missing (one line). A comparison figure needs one of its algorithms, the others every
    run."""
    from hiddpg.experiments import comparison
    from hiddpg.experiments.schedule import CHEAP_FIRST, figure_runs

    out: dict[str, str | None] = {}
    for name in CHEAP_FIRST:
        runs = figure_runs(ctx, name)
        if name in comparison.FIGURES:
            paths = [ctx.artifact_path(a, t) for a, t in runs]
            out[name] = None if any(map(is_artifact, paths)) else (
                f"no artifact of {', '.join(comparison.COMPARED)} on {comparison.FIGURES[name]}")
            continue
        missing = [ctx.artifact_path(a, t) for a, t in runs
                   if not is_artifact(ctx.artifact_path(a, t))]
        out[name] = f"no artifact {missing[0]}" if missing else None
    return out

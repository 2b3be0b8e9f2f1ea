"""Sweep specs: a TOML table of algorithms × tasks × seeds × presets × ``--set`` overrides,
expanded into validated configurations with deterministic names.

A sweep spec is a TOML table (docs/scaling.md; ``hiddpg sweep`` flags give the same keys)::

    algos = ["ddpg", "hi-ddpg"]          # a list or one string
    tasks = "PuckTrajectory1"
    seeds = "0-4"                        # default 0-14; presets = "quick" (default "paper")
    set = { episodes = 200 }             # fixed overrides of every run
    [grid]                               # the cartesian product of these lists
    "agent.learning_starts" = [100, 300]
    [[group]]                            # optional: runs = union of groups; a group inherits
    algos = "ddpg"                       # the keys above, replaces algos/tasks/seeds/presets
    grid = { "agent.tau" = [0.01, 0.005] }                # and extends set/grid

A Gymnasium task (``tasks = "Reacher-v5"``, ``gym:<id>``, ``module:Env-v0``) is named as for
``hiddpg train``; ``goal = ["8:-0.3:0.3", "9:-0.3:0.3"]`` and ``skills = "MODULE:FUNCTION"``
declare its goal and h-DDPG's skills as ``--goal`` and ``--skills`` do (a group replaces them).

Names are deterministic, ``<algo>-<task>-<preset>[-<key>=<value>...]-<hash>`` with a hash of
the whole config (seeds are not part of a config). A later group that gives an earlier run's
config on other seeds is a run of its own, its name suffixed ``-seeds-105-109``; a group that
gives an earlier run's config and seeds is that run. Every config is validated by
:func:`expand` before anything runs.
"""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
import json
import re
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hiddpg import runner
from hiddpg.configs import TrainConfig
from hiddpg.host.declare import declarations_scope, declare
from hiddpg.presets import make_config
from hiddpg.runs import make_trainer

SPEC_KEYS = ("algos", "tasks", "seeds", "presets", "set", "grid", "goal", "skills", "group")
#: keys of a group that replace the top-level value; ``set`` and ``grid`` extend it instead
REPLACED_KEYS = ("algos", "tasks", "seeds", "presets", "goal", "skills")
DEFAULT_SEEDS = "0-14"
DEFAULT_PRESET = "paper"
HASH_DIGITS = 8
LABEL_MAX_CHARS = 120
MAX_ERRORS_SHOWN = 10


class SweepError(ValueError):
    """A bad spec, or a run directory that does not match its spec: one clear message."""


@dataclass(frozen=True)
class SweepRun:
    """One configuration of a sweep: a run directory trained on all ``seeds`` at once."""

    name: str
    algo: str
    task: str
    preset: str
    sets: tuple[str, ...]
    seeds: tuple[int, ...]
    grid: tuple[tuple[str, Any], ...]
    config: TrainConfig
    goal: tuple[str, ...] = ()
    """A Gymnasium task's goal declaration, ``INDEX:LOW:HIGH`` entries (``--goal``)."""
    skills: str | None = None
    """A Gymnasium task's skills, ``MODULE:FUNCTION`` (``--skills``)."""

    def declaration(self) -> dict[str, Any]:
        """What the spec declares of the run's Gymnasium task (empty if nothing)."""
        return declaration(self.goal, self.skills)

    def declare(self) -> None:
        """Register the declaration in this process (a Ray worker builds the run itself)."""
        if self.goal or self.skills:
            declare(self.task, self.goal, self.skills)

    def describe(self) -> str:
        point = ", ".join(f"{k}={_json(v)}" for k, v in self.grid)
        return f"{self.algo} {self.task} preset {self.preset}" + (f", {point}" if point else "")

    def train_argv(self, out: Path) -> list[str]:
        """``hiddpg train`` arguments that create this run as ``out/name``."""
        argv = [self.algo, self.task, "--seeds", ",".join(map(str, self.seeds)),
                "--preset", self.preset]
        for item in self.sets:
            argv += ["--set", item]
        for entry in self.goal:
            argv += ["--goal", entry]
        if self.skills:
            argv += ["--skills", self.skills]
        return argv + ["--out", str(out), "--name", self.name]


# -- spec -------------------------------------------------------------------------------------
def load_spec(path: str | Path) -> dict[str, Any]:
    """The spec table of a TOML file."""
    try:
        with open(path, "rb") as f:
            return tomllib.load(f)
    except FileNotFoundError:
        raise SweepError(f"spec {path}: no such file") from None
    except tomllib.TOMLDecodeError as err:
        raise SweepError(f"spec {path}: not valid TOML: {err}") from None


def expand(spec: dict[str, Any], source: str = "spec") -> list[SweepRun]:
    """All runs of ``spec``, each config built and validated (env and agent constructed, nothing
    compiled). Raises :class:`SweepError` naming every bad key or value and the runs it hits."""
    _check_keys(spec, SPEC_KEYS, source)
    groups = spec.get("group")
    if groups is None:
        groups, wheres = [{}], [source]
    elif isinstance(groups, list) and groups and all(isinstance(g, dict) for g in groups):
        wheres = [f"{source} [[group]] {i + 1}" for i in range(len(groups))]
    else:
        raise SweepError(f"{source}: group must be an array of tables ([[group]] ...)")
    base = {k: v for k, v in spec.items() if k != "group"}
    points = []
    for group, where in zip(groups, wheres, strict=True):
        _check_keys(group, SPEC_KEYS[:-1], where)
        try:
            merged = _merge(base, group)
        except SweepError as err:
            raise SweepError(f"{where}: {err}") from None
        points += _points(merged, where)
    runs: list[SweepRun] = []
    errors: dict[str, list[str]] = {}
    names: dict[str, tuple[int, ...]] = {}  # a run's name -> its seeds
    for i, (algo, task, preset, seeds, sets, grid, goal, skills) in enumerate(points):
        try:
            with declarations_scope():  # a Gymnasium declaration holds for its own run only
                config = make_config(algo, declare(task, goal, skills), preset, sets)
                make_trainer(config)  # builds env and agent: validates env overrides too
        except (ValueError, TypeError) as err:
            point = "".join(f", {k}={_json(v)}" for k, v in grid)
            errors.setdefault(str(err), []).append(f"run {i + 1} ({algo} {task} preset "
                                                   f"{preset}{point})")
            continue
        name = run_name(config, grid, declaration(goal, skills))
        if name in names and names[name] != seeds:  # the same config on other seeds
            name = f"{name}-seeds-{'_'.join(runner.seed_ranges(seeds))}"
        if name not in names:  # two groups may give the same config and seeds: train it once
            names[name] = seeds
            runs.append(SweepRun(name, algo, config.task, preset, tuple(sets), seeds, grid,
                                 config, goal, skills))
    if errors:
        raise SweepError(_error_report(errors, len(points)))
    return runs


def declaration(goal: tuple[str, ...], skills: str | None) -> dict[str, Any]:
    """A Gymnasium task's ``goal`` entries and ``skills`` as a run records them (empty if
    neither is given)."""
    return {k: v for k, v in (("goal", list(goal)), ("skills", skills)) if v}


def _error_report(errors: dict[str, list[str]], n_runs: int) -> str:
    """Each distinct error once, with the first run it hits and how many more."""
    n_bad = sum(len(v) for v in errors.values())
    lines = [f"{n_bad} of {n_runs} runs are invalid:"]
    for message, hits in list(errors.items())[:MAX_ERRORS_SHOWN]:
        more = f" and {len(hits) - 1} more" if len(hits) > 1 else ""
        lines.append(f"  {hits[0]}{more}: {message}")
    if len(errors) > MAX_ERRORS_SHOWN:
        lines.append(f"  ... and {len(errors) - MAX_ERRORS_SHOWN} more distinct errors")
    return "\n".join(lines)


def _check_keys(table: dict[str, Any], allowed: tuple[str, ...], where: str) -> None:
    for key in table:
        if key not in allowed:
            hint = f" (did you mean {key + 's'!r}?)" if key + "s" in allowed else ""
            raise SweepError(f"{where}: unknown key {key!r}{hint}; allowed: {list(allowed)}")


def _merge(base: dict[str, Any], group: dict[str, Any]) -> dict[str, Any]:
    merged = dict(base)
    merged.update({k: group[k] for k in REPLACED_KEYS if k in group})
    merged["set"] = set_list(base.get("set", [])) + set_list(group.get("set", []))
    merged["grid"] = {**grid_table(base.get("grid", {})), **grid_table(group.get("grid", {}))}
    return merged


def _points(spec: dict[str, Any], where: str) -> list[tuple]:
    """``(algo, task, preset, seeds, sets, grid point, goal, skills)`` for every combination."""
    try:
        algos = _names(spec.get("algos"), "algos")
        tasks = _names(spec.get("tasks"), "tasks")
        presets = _names(spec.get("presets", DEFAULT_PRESET), "presets")
        seeds = _seeds(spec.get("seeds", DEFAULT_SEEDS))
        goal = tuple(_names(spec["goal"], "goal")) if "goal" in spec else ()
        skills = spec.get("skills")
        if skills is not None and not isinstance(skills, str):
            raise SweepError(f"skills = {skills!r} must be a string MODULE:FUNCTION")
    except SweepError as err:
        raise SweepError(f"{where}: {err}") from None
    grid = spec["grid"]
    out = []
    for algo, task, preset in itertools.product(algos, tasks, presets):
        for values in itertools.product(*grid.values()):
            point = tuple(zip(grid, values, strict=True))
            sets = spec["set"] + [_set_string(k, v) for k, v in point]
            out.append((algo, task, preset, seeds, sets, point, goal, skills))
    return out


def _names(value: Any, key: str) -> list[str]:
    if value is None:
        raise SweepError(f"{key} is required (e.g. {key} = [...])")
    items = [value] if isinstance(value, str) else value
    if not isinstance(items, list) or not items or not all(isinstance(v, str) for v in items):
        raise SweepError(f"{key} = {value!r} must be a string or a non-empty list of strings")
    return items


def _seeds(value: Any) -> tuple[int, ...]:
    if isinstance(value, str):
        try:
            return tuple(runner.parse_seeds(value))
        except ValueError as err:
            raise SweepError(str(err)) from None
    items = [value] if isinstance(value, int) and not isinstance(value, bool) else value
    if (not isinstance(items, list) or not items
            or not all(isinstance(s, int) and not isinstance(s, bool) for s in items)):
        raise SweepError(f"seeds = {value!r} must be a range '0-4', a list of ints or an int")
    if len(set(items)) != len(items):
        raise SweepError(f"seeds = {value!r} has a seed twice")
    return tuple(items)


def set_list(value: Any) -> list[str]:
    """``set`` as a table ``{key = value}`` or a list of ``"key=value"`` strings."""
    if isinstance(value, dict):
        return [_set_string(k, v) for k, v in _flatten(value)]
    if isinstance(value, list) and all(isinstance(v, str) and "=" in v for v in value):
        return list(value)
    raise SweepError(f"set = {value!r} must be a table {{key = value}} or a list of "
                     "'key=value' strings")


def grid_table(value: Any) -> dict[str, list]:
    if not isinstance(value, dict):
        raise SweepError(f"grid = {value!r} must be a table of lists, e.g. "
                         "[grid] \"agent.tau\" = [0.01, 0.005]")
    grid = {}
    for k, v in _flatten(value):
        if not isinstance(v, list) or not v:
            raise SweepError(f"grid.{k} = {v!r} must be a non-empty list of values, e.g. "
                             f"[{_json(v)}]")
        grid[k] = v
    return grid


def _flatten(table: dict[str, Any], prefix: str = ""):
    for k, v in table.items():
        if isinstance(v, dict):
            yield from _flatten(v, f"{prefix}{k}.")
        else:
            yield f"{prefix}{k}", v


def _json(value: Any) -> str:
    return value if isinstance(value, str) else json.dumps(value, separators=(",", ":"))


def _set_string(key: str, value: Any) -> str:
    """A ``--set`` string that :func:`hiddpg.presets.apply_overrides` parses back to value."""
    return f"{key}={_json(value)}"


# -- names ------------------------------------------------------------------------------------
def config_hash(config: TrainConfig, declared: dict[str, Any] | None = None) -> str:
    """A hash of the config's values that differ from their defaults: a field added to a config
    class later, at its default, leaves the names of existing runs unchanged. A Gymnasium
    task's ``declared`` goal and skills count too (none: the names of other runs unchanged)."""
    values = _non_defaults(config)
    if declared:
        values = {"config": values, "declared": declared}
    text = json.dumps(values, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:HASH_DIGITS]


def _non_defaults(value: Any) -> Any:
    """``to_dict``-like, without the dataclass fields that hold their default."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        out: dict[str, Any] = {"_type": type(value).__name__}
        for f in dataclasses.fields(value):
            v = getattr(value, f.name)
            if f.default is not dataclasses.MISSING:
                default = f.default
            elif f.default_factory is not dataclasses.MISSING:
                default = f.default_factory()
            else:
                default = dataclasses.MISSING
            if default is dataclasses.MISSING or v != default:
                out[f.name] = _non_defaults(v)
        return out
    if isinstance(value, list | tuple):
        return [_non_defaults(x) for x in value]
    return value


def run_name(config: TrainConfig, grid: tuple[tuple[str, Any], ...] = (),
             declared: dict[str, Any] | None = None) -> str:
    """``<algo>-<task>-<preset>[-<key>=<value>...]-<hash>``: readable, unique, deterministic."""
    def label(v: Any) -> str:
        if isinstance(v, list) and all(isinstance(x, int | float) for x in v):
            return "x".join(_json(x) for x in v)
        return _json(v)

    parts = [config.algo, config.task, config.preset] + [f"{k}={label(v)}" for k, v in grid]
    parts = [re.sub(r"[^A-Za-z0-9._=+-]+", "_", p) for p in parts]
    text = "-".join(parts[:3])
    for part in parts[3:]:  # whole grid parts while they fit; the hash keeps names unique
        if len(text) + 1 + len(part) > LABEL_MAX_CHARS:
            break
        text += "-" + part
    return f"{text}-{config_hash(config, declared)}"

"""A Gymnasium task named on the command line: which ids are Gymnasium's, the ``--goal`` and
``--skills`` declarations, and where a host run's values come from.

``hiddpg train`` takes a task as ``gym:<id>``, a bare Gymnasium id (``Reacher-v5``) or
``module:Env-v0`` (Gymnasium imports ``module`` first); our own tasks keep their names and the
JAX engine (``PuckTrajectory1``, ``hiddpg/PuckTrajectory1-v0``, ``my_pkg.slider:Slider``).
A goal is declared one observation entry at a time, ``--goal INDEX:LOW:HIGH`` (repeatable)::

    hiddpg train hi-ddpg gym:Reacher-v5 --goal 8:-0.3:0.3 --goal 9:-0.3:0.3

The declaration is registered (:func:`hiddpg.host.register_gym_task`) under the id for the
command's duration only (:func:`declarations_scope`); the run directory records it
(``config.json``'s ``gym_task``), so ``--resume`` and ``hiddpg eval`` repeat it in a fresh
process without it being given again.
"""

from __future__ import annotations

import contextlib
import difflib
import math
import re
from collections.abc import Iterator, Sequence
from typing import Any

from hiddpg.envs.registry import resolve
from hiddpg.host.task import GYM_TASKS, PREFIX, gym_task, is_gym_task, register_gym_task

#: what one ``--goal`` entry looks like, for messages and ``--help``.
GOAL_SYNTAX = "INDEX:LOW:HIGH (an observation index and its bounds, e.g. 8:-0.3:0.3)"
#: a Python attribute path: what follows the colon of our own ``module:Class`` tasks.
_ATTRIBUTE = re.compile(r"[A-Za-z_][\w.]*")


def parse_goal(entries: Sequence[str]) -> dict[int, tuple[float, float]] | None:
    """``--goal`` entries as ``{index: (low, high)}`` (None if there are none); ``ValueError``
    (one line) naming a malformed entry, a negative or repeated index, a bound that is not a
    finite number or ``low >= high``."""
    goal: dict[int, tuple[float, float]] = {}
    for entry in entries:
        parts = entry.split(":")
        where = f"--goal {entry!r}"
        if len(parts) != 3:
            raise ValueError(f"{where}: give {GOAL_SYNTAX}")
        try:
            index = int(parts[0])
        except ValueError:
            raise ValueError(f"{where}: INDEX {parts[0]!r} must be an integer >= 0") from None
        try:
            low, high = float(parts[1]), float(parts[2])
        except ValueError:
            raise ValueError(f"{where}: LOW and HIGH must be numbers; give {GOAL_SYNTAX}"
                             ) from None
        if index < 0:
            raise ValueError(f"{where}: INDEX {index} must be >= 0")
        if not (math.isfinite(low) and math.isfinite(high)):
            raise ValueError(f"{where}: LOW and HIGH must be finite numbers")
        if not low < high:
            raise ValueError(f"{where}: LOW {low:g} must be below HIGH {high:g}")
        if index in goal:
            raise ValueError(f"{where}: index {index} is declared twice")
        goal[index] = (low, high)
    return goal or None


def _gym_ids() -> list[str]:
    import gymnasium

    import hiddpg  # noqa: F401  (registers our adapters, hiddpg/*)

    return list(gymnasium.registry)


def _unknown(task: str) -> ValueError:
    """An unknown task, with the closest names among ours and Gymnasium's."""
    from hiddpg.envs.registry import TASKS

    names = [*TASKS, *_gym_ids()]
    close = difflib.get_close_matches(task.removeprefix(PREFIX), names, n=3, cutoff=0.6)
    hint = f"; did you mean {', '.join(close)}?" if close else ""
    return ValueError(f"unknown task {task!r}: not one of ours (hiddpg envs list), yours "
                      f"(module:Class) or a Gymnasium id (gym:<id>, module:Env-v0){hint}")


def resolve_task(task: str) -> str:
    """The ``TrainConfig.task`` a command-line TASK names: ``gym:<id>`` for a Gymnasium task
    (a ``gym:`` name, an id only Gymnasium knows, or ``module:Id`` whose ``Id`` is no Python
    name, e.g. ``my_pkg.envs:Slider-v0``), else ``task`` itself (our tasks, checked by
    :func:`hiddpg.presets.make_config`). ``ValueError`` naming an unknown id, with close names."""
    if is_gym_task(task):
        name = task[len(PREFIX):]
        if not name:
            raise ValueError(f"task {task!r}: name a Gymnasium id after {PREFIX!r}, e.g. "
                             f"{PREFIX}Pendulum-v1")
        if ":" not in name and name not in GYM_TASKS and name not in _gym_ids():
            raise _unknown(task)
        return task
    module, colon, attr = task.partition(":")
    if colon:
        return task if _ATTRIBUTE.fullmatch(attr) else PREFIX + task
    from hiddpg.envs.registry import task_name

    try:
        task_name(task)
        return task
    except ValueError:
        if task in _gym_ids():
            return PREFIX + task
        raise _unknown(task) from None


def declare(task: str, goal: Sequence[str] = (), skills: str | None = None) -> str:
    """Resolve ``task`` (:func:`resolve_task`) and register the declaration ``--goal`` and
    ``--skills`` give it; returns the ``TrainConfig.task``. ``ValueError`` (one line) for a
    bad entry, or a declaration given for one of our own tasks."""
    resolved = resolve_task(task)
    goals = parse_goal(goal)
    if goals is None and skills is None:
        return resolved
    if not is_gym_task(resolved):
        flag = "--goal" if goals is not None else "--skills"
        raise ValueError(f"{flag} declares a Gymnasium task's goal or skills; {task!r} is one "
                         "of ours and has its own (hiddpg envs list)")
    name = resolved[len(PREFIX):]
    module, _, attr = (skills or "").partition(":")
    if skills is not None and not (module and _ATTRIBUTE.fullmatch(attr)):
        raise ValueError(f"--skills {skills!r}: give MODULE:FUNCTION, a factory "
                         "(env, config) -> hiddpg.agents.skills.SkillPatterns")
    if skills is not None:
        try:
            resolve(skills)
        except ValueError as err:
            raise ValueError(f"--skills {err}") from None
    own = gym_task(resolved)
    register_gym_task(name, own.env, goal=goals if goals is not None else own.goal,
                      skills=skills if skills is not None else own.skills,
                      max_episode_steps=own.max_episode_steps, dt=own.dt, params=own.params,
                      vectorization=own.vectorization, summary=own.summary)
    return resolved


@contextlib.contextmanager
def declarations_scope() -> Iterator[None]:
    """Gymnasium declarations made inside (by a command line, or repeated from a run
    directory) are forgotten on leaving, with the trainers built for them, so that one
    process can run several commands, each with its own declaration of the same id."""
    before = dict(GYM_TASKS)
    try:
        yield
    finally:
        if GYM_TASKS != before:
            GYM_TASKS.clear()
            GYM_TASKS.update(before)
            from hiddpg import train

            # trainers are cached by config, whose task names the id but not its declaration
            for config in [c for c in train._TRAINERS if is_gym_task(c.task)]:
                del train._TRAINERS[config]


def directory_name(task: str) -> str:
    """A Gymnasium task's id as a part of a run's directory name: the characters a directory
    name cannot hold (``:``, ``/``) as ``_`` (``gym:my_pkg:Slider-v0`` -> ``my_pkg_Slider-v0``)."""
    return re.sub(r"[^A-Za-z0-9._+=@-]", "_", task.removeprefix(PREFIX))


def value_sources(config: Any, env: Any) -> dict[str, Any]:
    """Where a host run's values come from: the preset's generic values, what the
    environment says of itself, and what was declared (``config.json``'s ``sources``)."""
    from hiddpg.host.catalog import catalogued  # the shipped declarations

    declared = gym_task(config.task)
    shipped = catalogued(config.task[len(PREFIX):])
    goal = env.goal_space

    def origin(part: str, own: Any) -> str | None:
        """Where the goal or skills (``part``) come from; ``own``: the environment's value."""
        value = getattr(declared, part)
        if value is None:
            return None if own is None else "the environment"
        if shipped is not None and value == getattr(shipped, part):
            return "hiddpg.host.catalog (shipped with hiddpg)"
        return f"--{part} / register_gym_task"

    goal_from, skills_from = origin("goal", goal), origin("skills", env.skills)
    return {
        "preset": f"{config.preset}: its generic values (networks, learning rates, noise, "
                  "buffers, gamma, tau, budget), as for a task of no family; nothing of the "
                  "puck or arm tasks",
        "environment": {"obs_dim": env.obs_dim, "action_dim": env.action_dim,
                        "action_box": [env.box_low.tolist(), env.box_high.tolist()],
                        "horizon": env.horizon, "dt": env.dt},
        "goal": None if goal is None else {
            "from": goal_from,
            "entries": {str(i): [lo, hi] for i, lo, hi in zip(goal.indices, goal.low,
                                                              goal.high, strict=True)}},
        "skills": None if env.skills is None else str(env.skills),
        "skills_from": skills_from,
    }


def record_sources(path: Any, config: Any, env: Any) -> dict[str, Any]:
    """Add :func:`value_sources` to the ``config.json`` of the new host run in ``path``;
    returns them."""
    import json

    from hiddpg.run_files import atomic_write
    from hiddpg.runs import CONFIG_FILE

    meta = json.loads((path / CONFIG_FILE).read_text())
    meta["sources"] = value_sources(config, env)
    atomic_write(path / CONFIG_FILE, (json.dumps(meta, indent=2) + "\n").encode())
    return meta["sources"]


def sources_line(sources: dict[str, Any]) -> str:
    """:func:`value_sources` as one printed line."""
    env = sources["environment"]
    text = (f"values: preset {sources['preset']}; from the environment: observation "
            f"{env['obs_dim']}, action {env['action_dim']}, horizon {env['horizon']}, "
            f"dt {env['dt']:g}")
    goal = sources["goal"]
    if goal is not None:
        entries = ", ".join(f"{i} in [{lo:g}, {hi:g}]" for i, (lo, hi) in goal["entries"].items())
        text += f"; goal {entries} (from {goal['from']})"
    if sources["skills"] is not None:
        text += f"; skills {sources['skills']}"
        if sources.get("skills_from"):
            text += f" (from {sources['skills_from']})"
    return text

"""Gymnasium tasks of the host-loop engine: the environment, the goal space, h-DDPG's skills.

A task of the host engine is named ``gym:<name>``: ``<name>`` is a name given to
:func:`register_gym_task` or any Gymnasium id (``gym:Pendulum-v1``,
``gym:hiddpg/PuckTrajectory1-v0``, ``gym:my_pkg.envs:Slider-v0`` -- Gymnasium imports
``my_pkg.envs`` first). An id nobody registered trains with what the environment itself says:
flat DDPG works on any continuous Box task; our own tasks' adapters (``hiddpg/*``) bring their
goal space, skills and horizon along. For HI-DDPG on another environment declare which
observation entries a goal fixes, and their bounds::

    from hiddpg.host import register_gym_task
    register_gym_task("Reacher-v5", goal={8: (-0.3, 0.3), 9: (-0.3, 0.3)})
    # TrainConfig(task="gym:Reacher-v5", ...)

A declaration is data: :class:`GymTask`. Building the environment and checking what can work
is :mod:`hiddpg.host.env`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from typing import Any

from hiddpg.envs.base import GoalSpace
from hiddpg.envs.registry import _reference, resolve

#: the prefix that names a host-engine task in ``TrainConfig.task``.
PREFIX = "gym:"
#: how the seeds' environments are stepped: one process (``sync``) or one process each.
VECTORIZATIONS = ("sync", "async")


@dataclasses.dataclass(frozen=True)
class GymTask:
    """What the host engine needs to know of a Gymnasium environment beyond its spaces.

    Attributes:
        env: a Gymnasium id (``"Reacher-v5"``, ``"my_pkg.envs:Slider-v0"``) or a factory
            ``(**kwargs) -> gymnasium.Env``; ``TrainConfig.env`` pairs are its keyword arguments.
        goal: which observation entries HI-DDPG's goals fix and their bounds, a
            :class:`~hiddpg.envs.GoalSpace` or ``{index: (low, high)}``; None: the environment's
            own (our adapters'), else HI-DDPG refuses the task.
        skills: h-DDPG's movement patterns, ``(env, config) -> SkillPatterns`` (``env`` the
            :class:`~hiddpg.host.env.HostEnv`) or its ``"module:name"``; None: our adapters'
            own, else h-DDPG refuses the task.
        max_episode_steps: the horizon; None: the id's ``max_episode_steps`` (its
            ``TimeLimit``), else the adapter's ``max_steps``.
        dt: the control period HI-DDPG's low-level model scales by (``s' = s + dt f(s, a)``);
            None: the environment's ``dt`` attribute if it has one, else 1.
        params: what h-DDPG's skills receive as ``env_params`` (our adapters: the core's).
        vectorization: ``"sync"`` (every seed's environment in this process) or ``"async"``
            (one subprocess each, :class:`gymnasium.vector.AsyncVectorEnv`).
        summary: one line describing the task.
    """

    env: str | Callable[..., Any]
    goal: GoalSpace | None = None
    skills: Any = None
    max_episode_steps: int | None = None
    dt: float | None = None
    params: Any = None
    vectorization: str = "sync"
    summary: str = ""

    def __post_init__(self) -> None:
        where = f"GymTask(env={self.env!r})"
        if not (isinstance(self.env, str) and self.env) and not callable(self.env):
            raise ValueError(f"{where}: env must be a Gymnasium id or a factory returning a "
                             "gymnasium.Env")
        object.__setattr__(self, "goal", goal_space(self.goal, where))
        steps = self.max_episode_steps
        if steps is not None and (isinstance(steps, bool) or not isinstance(steps, int)
                                  or steps < 1):
            raise ValueError(f"{where}: max_episode_steps={steps!r} must be an int >= 1")
        if self.dt is not None and not (isinstance(self.dt, int | float) and self.dt > 0):
            raise ValueError(f"{where}: dt={self.dt!r} must be a number > 0")
        if self.vectorization not in VECTORIZATIONS:
            raise ValueError(f"{where}: vectorization={self.vectorization!r} is not allowed; "
                             f"choose one of {list(VECTORIZATIONS)}")


    def declaration(self) -> dict[str, Any] | None:
        """This declaration as JSON-ready data (a factory as ``"factory": "module:name"``), to
        repeat it in another process (:func:`restore_gym_task`); None if a part cannot be
        named (a lambda, a class of ``__main__``, ``params``)."""
        if self.params is not None:
            return None
        out: dict[str, Any] = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)
                               if f.name not in ("env", "params", "goal")}
        if isinstance(self.env, str):
            out["env"] = self.env
        else:
            out["factory"] = _reference(self.env)
        if self.skills is not None and not isinstance(self.skills, str):
            out["skills"] = _reference(self.skills)
        if out.get("factory", "") is None or (self.skills is not None and out["skills"] is None):
            return None
        goal = self.goal
        out["goal"] = None if goal is None else {str(i): [lo, hi] for i, lo, hi in zip(
            goal.indices, goal.low, goal.high, strict=True)}
        return out


def goal_space(goal: Any, where: str = "goal") -> GoalSpace | None:
    """``goal`` as a :class:`GoalSpace`: one already, ``{index: (low, high)}`` or None."""
    if goal is None or isinstance(goal, GoalSpace):
        return goal
    if not isinstance(goal, Mapping) or not goal:
        raise ValueError(f"{where}: goal={goal!r} must be a GoalSpace or a non-empty "
                         "{observation index: (low, high)} mapping")
    try:
        items = sorted((int(i), (float(b[0]), float(b[1]))) for i, b in goal.items())
        if any(len(b) != 2 for b in goal.values()):
            raise ValueError
    except (TypeError, ValueError, IndexError):
        raise ValueError(f"{where}: goal={goal!r} must map observation indices to (low, high) "
                         "pairs of numbers") from None
    try:
        return GoalSpace(indices=tuple(i for i, _ in items),
                         low=tuple(b[0] for _, b in items), high=tuple(b[1] for _, b in items))
    except ValueError as err:
        raise ValueError(f"{where}: {err}") from None


#: the registered declarations, by name (without the ``gym:`` prefix).
GYM_TASKS: dict[str, GymTask] = {}


def register_gym_task(name: str, env: str | Callable[..., Any] | None = None, *,
                      goal: Any = None, skills: Any = None,
                      max_episode_steps: int | None = None, dt: float | None = None,
                      params: Any = None, vectorization: str = "sync",
                      summary: str = "") -> GymTask:
    """Declare the Gymnasium task ``gym:<name>`` (see :class:`GymTask` for the arguments;
    ``env`` defaults to ``name``, a Gymnasium id). Registering a name again with the same
    declaration returns it; with another one raises ``ValueError``."""
    if not isinstance(name, str) or not name or name.startswith(PREFIX):
        raise ValueError(f"register_gym_task: name={name!r} must be a non-empty string without "
                         f"the {PREFIX!r} prefix")
    task = GymTask(env=name if env is None else env, goal=goal, skills=skills,
                   max_episode_steps=max_episode_steps, dt=dt, params=params,
                   vectorization=vectorization, summary=summary)
    old = GYM_TASKS.get(name)
    if old == task:
        return old
    if old is not None:
        raise ValueError(f"register_gym_task: {PREFIX}{name} is already declared as {old}; "
                         "unregister it first or choose another name")
    GYM_TASKS[name] = task
    return task


def restore_gym_task(task: str | None, declaration: dict[str, Any] | None) -> None:
    """Repeat the registration of ``task`` (``gym:<name>``) recorded by
    :meth:`GymTask.declaration`, unless the name is declared already or nothing was recorded."""
    if not declaration or not is_gym_task(task) or task[len(PREFIX):] in GYM_TASKS:
        return
    name = task[len(PREFIX):]
    data = dict(declaration)
    env = resolve(data.pop("factory")) if "factory" in data else data.pop("env")
    register_gym_task(name, env, **data)


def unregister_gym_task(name: str) -> None:
    """Forget the declaration of ``gym:<name>`` (nothing happens if there is none)."""
    GYM_TASKS.pop(name, None)


def is_gym_task(task: Any) -> bool:
    """Whether ``task`` (a ``TrainConfig.task``) names a host-engine task."""
    return isinstance(task, str) and task.startswith(PREFIX)


def gym_task(task: str) -> GymTask:
    """The declaration of ``gym:<name>``: the registered one, else the shipped one
    (:mod:`hiddpg.host.catalog`), else ``GymTask(env=<name>)``."""
    if not is_gym_task(task) or len(task) == len(PREFIX):
        raise ValueError(f"task {task!r} is not a host-engine task; name one as "
                         f"'{PREFIX}<Gymnasium id>' (e.g. '{PREFIX}Pendulum-v1') or register "
                         "it with hiddpg.host.register_gym_task")
    name = task[len(PREFIX):]
    if name in GYM_TASKS:
        return GYM_TASKS[name]
    from hiddpg.host.catalog import catalogued  # the shipped declarations (imports no env)

    return catalogued(name) or GymTask(env=name)

"""The task registry: each task's environment, family, h-DDPG skills and observation bounds.

``make("PuckTrajectory2")``, ``make("hiddpg/PuckTrajectory2-v0")`` and
``make("PuckTrajectory2-v0", field="cw")`` all work and return ``(env, params)``. Users add
tasks with :func:`register_task`; a ``"module:Class"`` task id is imported and registered on
first use.
"""

from __future__ import annotations

import dataclasses
import functools
import importlib
import importlib.util
import re
import weakref
from collections.abc import Callable
from typing import Any

from hiddpg.envs.base import Environment

NAMESPACE = "hiddpg"
VERSION = "v0"
#: Task families: presets pick their values by family; ``"custom"`` is the generic one.
FAMILIES = ("puck", "arm", "custom")


@dataclasses.dataclass(frozen=True)
class TaskSpec:
    """A registered task. ``target`` is a ``"module:Class"`` string, an :class:`Environment`
    subclass or a zero-argument factory; ``skills`` and ``obs_bounds`` are callables,
    ``"module:function"`` strings or None (see :func:`register_task`)."""

    name: str
    target: Any
    summary: str = ""
    family: str = "custom"
    skills: Any = None
    obs_bounds: Any = None

    @property
    def env_id(self) -> str:
        return f"{NAMESPACE}/{self.name}-{VERSION}"

    def load(self) -> Callable[[], Environment]:
        """The class or factory that builds this task's environment."""
        return resolve(self.target)

    @functools.cached_property
    def env_type(self) -> type:
        """The class of this task's environment (a factory is called once to find it)."""
        target = self.load()
        return target if isinstance(target, type) else type(target())

    def skill_factory(self) -> Callable[[Any, Any], Any] | None:
        """``(env, config) -> SkillPatterns`` for h-DDPG, or None if the task declares none."""
        return None if self.skills is None else resolve(self.skills)

    def bounds_function(self) -> Callable[[Any, Any], Any] | None:
        """``(env, params) -> (low, high)`` for the Gymnasium observation box, or None."""
        return None if self.obs_bounds is None else resolve(self.obs_bounds)

    def declaration(self) -> dict[str, Any] | None:
        """This registration as ``"module:name"`` strings, to repeat it in another process;
        None if an entry cannot be imported by name (a lambda, a class of ``__main__``)."""
        out: dict[str, Any] = {"name": self.name, "family": self.family, "summary": self.summary}
        for key in ("target", "skills", "obs_bounds"):
            value = getattr(self, key)
            out[key] = value if value is None or isinstance(value, str) else _reference(value)
            if value is not None and out[key] is None:
                return None
        return out


def resolve(ref: Any) -> Any:
    """The object a ``"module:name"`` string names; any other value is returned as is."""
    if not isinstance(ref, str):
        return ref
    module, sep, attr = ref.partition(":")
    if not sep or not module or not attr:
        raise ValueError(f"{ref!r} is not a 'module:name' reference")
    try:
        obj: Any = importlib.import_module(module)
    except ImportError as err:
        raise ValueError(f"{ref!r}: cannot import module {module!r} ({err})") from None
    for part in attr.split("."):
        if not hasattr(obj, part):
            raise ValueError(f"{ref!r}: module {module!r} has no attribute {attr!r}")
        obj = getattr(obj, part)
    return obj


def _reference(obj: Any) -> str | None:
    module, qualname = getattr(obj, "__module__", None), getattr(obj, "__qualname__", "")
    if not module or module == "__main__" or not qualname or "<" in qualname:
        return None
    return f"{module}:{qualname}"


def _puck(name: str, summary: str) -> TaskSpec:
    return TaskSpec(name, f"hiddpg.envs.puckworld:{name}", summary, "puck",
                    "hiddpg.agents.skills:puck_skills", "hiddpg.envs.bounds:puck_bounds")


def _arm(name: str, summary: str) -> TaskSpec:
    return TaskSpec(name, f"hiddpg.envs.arm_tasks:{name}", summary, "arm",
                    "hiddpg.agents.skills:arm_skills", "hiddpg.envs.bounds:arm_bounds")


TASKS: dict[str, TaskSpec] = {
    t.name: t
    for t in (
        _puck("PuckTrajectory1", "puck follows a 30-step reference through 1 goal"),
        _puck("PuckTrajectory2",
              "puck follows a 30-step reference through 2 goals (switch at step 15)"),
        _puck("PuckTrajectory3",
              "puck follows a 30-step reference through 3 goals (switches at 10, 20)"),
        _puck("PuckObstacle",
              "puck reaches [2, 0] around a disc at [1, 0]; collision ends the episode"),
        _arm("ArmReach", "6-muscle arm reaches a random joint-space target in 1 s"),
        _arm("ArmObstacle", "6-muscle arm reaches (90°, 60°) without touching an obstacle"),
    )
}
#: The tasks hiddpg ships.
BUILTIN_TASKS = frozenset(TASKS)


def register_task(name: str, entry: Any, *, family: str = "custom", skills: Any = None,
                  summary: str = "", obs_bounds: Any = None) -> TaskSpec:
    """Register a task so that presets, ``make_config``, the CLI, Gymnasium
    (``hiddpg/<name>-v0``) and iLQR know it; see docs/usage.md.

    Args:
        name: the task's name, e.g. ``"Slider"`` (letters, digits, ``_``, ``.``, ``-``).
        entry: a ``"module:Class"`` string, an :class:`Environment` subclass or a
            zero-argument factory returning an instance.
        family: which presets' values the task gets: ``"puck"``, ``"arm"`` or ``"custom"``.
        skills: h-DDPG's skills, ``(env, config) -> SkillPatterns`` (or its ``"module:name"``);
            None: h-DDPG refuses the task.
        summary: one line for ``hiddpg envs list``.
        obs_bounds: ``(env, params) -> (low, high)`` for the Gymnasium observation box; None:
            the environment's ``observation_bounds(params)`` if it has one, else ``±1e4``.

    Registering a name again with the same declaration returns the existing spec; with another
    one it raises ``ValueError``.
    """
    where = f"register_task({name!r}, {entry!r})"
    if not isinstance(name, str) or not re.fullmatch(r"[A-Za-z][\w.-]*", name) or re.search(
            r"-v\d+$", name):
        raise ValueError(f"{where}: the name must start with a letter, hold only letters, "
                         "digits, '_', '.' and '-', and not end in a version like '-v0'")
    if family not in FAMILIES:
        raise ValueError(f"{where}: family={family!r} is unknown; choose one of {list(FAMILIES)}")
    for key, value in (("skills", skills), ("obs_bounds", obs_bounds)):
        if value is not None and not callable(resolve(value)):
            raise ValueError(f"{where}: {key}={value!r} is not callable")
    spec = TaskSpec(name, entry, summary, family, skills, obs_bounds)
    _check_entry(spec, where)
    old = TASKS.get(name)
    if old is not None:
        if _same(old, spec):
            return old
        raise ValueError(f"{where}: task {name!r} is already registered to {old.target!r} "
                         f"(family {old.family!r}, skills {old.skills!r}); register this one "
                         "under another name")
    TASKS[name] = spec
    if importlib.util.find_spec("gymnasium") is not None:
        from hiddpg.envs.gym import register_envs

        register_envs()
    return spec


def unregister_task(name: str) -> None:
    """Remove a task added by :func:`register_task` (and its Gymnasium id); built-in tasks stay."""
    if name in BUILTIN_TASKS:
        raise ValueError(f"{name!r} is a built-in task and cannot be unregistered")
    spec = TASKS.pop(name, None)
    if spec is not None and importlib.util.find_spec("gymnasium") is not None:
        import gymnasium

        gymnasium.registry.pop(spec.env_id, None)


def _check_entry(spec: TaskSpec, where: str) -> None:
    target = spec.load()
    if isinstance(target, Environment):
        raise ValueError(f"{where}: the entry is an Environment instance; pass its class "
                         f"{type(target).__name__} or a zero-argument factory")
    if isinstance(target, type) and not issubclass(target, Environment):
        raise ValueError(f"{where}: {target.__name__} is not a subclass of "
                         "hiddpg.envs.Environment")
    if not callable(target):
        raise ValueError(f"{where}: the entry must be a 'module:Class' string, an Environment "
                         f"subclass or a zero-argument factory, got {type(target).__name__}")
    try:
        env = target()
    except Exception as err:
        raise ValueError(f"{where}: calling it with no arguments failed: {err!r}") from err
    if not isinstance(env, Environment):
        raise ValueError(f"{where}: the factory returned {type(env).__name__}, not a "
                         "hiddpg.envs.Environment")


def _same(a: TaskSpec, b: TaskSpec) -> bool:
    return all(resolve(getattr(a, k)) is resolve(getattr(b, k)) or getattr(a, k) == getattr(b, k)
               for k in ("target", "skills", "obs_bounds")) and a.family == b.family


def restore_task(declaration: dict[str, Any] | None) -> None:
    """Repeat a registration recorded by :meth:`TaskSpec.declaration` unless its name is known."""
    if declaration and declaration["name"] not in TASKS:
        register_task(declaration["name"], declaration["target"],
                      family=declaration.get("family", "custom"),
                      skills=declaration.get("skills"), summary=declaration.get("summary", ""),
                      obs_bounds=declaration.get("obs_bounds"))


def _from_reference(task: str) -> str:
    """Import ``"module:Class"``: the name it is registered under (its class name if new)."""
    target = resolve(task)
    for spec in TASKS.values():
        if spec.target == task or spec.load() is target:
            return spec.name
    name = task.rpartition(":")[2].rpartition(".")[2]
    register_task(name, task, summary=f"registered from {task}")
    return name


def task_name(task: str) -> str:
    """Normalise ``hiddpg/Name-v0``, ``Name-v0`` or ``Name`` to ``Name``, importing and
    registering a ``"module:Class"`` id; ``ValueError`` if unknown."""
    if ":" in task and "/" not in task:
        try:
            return _from_reference(task)
        except ValueError as err:
            raise ValueError(f"unknown task {task!r}: {err}") from None
    name = task
    if name.startswith(NAMESPACE + "/"):
        name = name[len(NAMESPACE) + 1:]
    if name.endswith("-" + VERSION):
        name = name[: -len(VERSION) - 1]
    if name not in TASKS:
        raise ValueError(
            f"unknown task {task!r}; known tasks: {[t.env_id for t in TASKS.values()]} (or "
            "register yours with hiddpg.register_task, or give it as 'module:Class')"
        )
    return name


#: ``id(env) -> task name`` of the environments :func:`make` built and that are still alive.
_BUILT: dict[int, str] = {}


def spec_of(env: Environment) -> TaskSpec | None:
    """The task :func:`make` built ``env`` for, else the first registered task whose
    environment has ``env``'s exact class, else None."""
    name = _BUILT.get(id(env))
    if name in TASKS:
        return TASKS[name]
    return next((s for s in TASKS.values() if s.env_type is type(env)), None)


def make(task: str, **overrides: Any) -> tuple[Environment, Any]:
    """Build a task's functional core and its params (spec defaults, then ``overrides``)."""
    name = task_name(task)
    env = TASKS[name].load()()
    try:
        weakref.finalize(env, _BUILT.pop, id(env), None)
        _BUILT[id(env)] = name
    except TypeError:  # a class without weak references: spec_of goes by the class
        pass
    return env, env.default_params(**overrides)

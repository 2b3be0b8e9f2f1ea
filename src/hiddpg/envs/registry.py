"""The task registry: names, descriptions and ``make``.

``make("PuckTrajectory2")``, ``make("hiddpg/PuckTrajectory2-v0")`` and
``make("PuckTrajectory2-v0", field="cw")`` all work and return ``(env, params)``.
"""

from __future__ import annotations

import dataclasses
import importlib
from typing import Any

from hiddpg.envs.base import Environment

NAMESPACE = "hiddpg"
VERSION = "v0"


@dataclasses.dataclass(frozen=True)
class TaskSpec:
    name: str
    target: str  # "module:Class"
    summary: str

    @property
    def env_id(self) -> str:
        return f"{NAMESPACE}/{self.name}-{VERSION}"

    def load(self) -> type[Environment]:
        module, cls = self.target.split(":")
        return getattr(importlib.import_module(module), cls)


TASKS: dict[str, TaskSpec] = {
    t.name: t
    for t in (
        TaskSpec("PuckTrajectory1", "hiddpg.envs.puckworld:PuckTrajectory1",
                 "puck follows a 30-step reference through 1 goal"),
        TaskSpec("PuckTrajectory2", "hiddpg.envs.puckworld:PuckTrajectory2",
                 "puck follows a 30-step reference through 2 goals (switch at step 15)"),
        TaskSpec("PuckTrajectory3", "hiddpg.envs.puckworld:PuckTrajectory3",
                 "puck follows a 30-step reference through 3 goals (switches at 10, 20)"),
        TaskSpec("PuckObstacle", "hiddpg.envs.puckworld:PuckObstacle",
                 "puck reaches [2, 0] around a disc at [1, 0]; collision ends the episode"),
        TaskSpec("ArmReach", "hiddpg.envs.arm_tasks:ArmReach",
                 "6-muscle arm reaches a random joint-space target in 1 s"),
        TaskSpec("ArmObstacle", "hiddpg.envs.arm_tasks:ArmObstacle",
                 "6-muscle arm reaches (90°, 60°) without touching an obstacle"),
    )
}


def task_name(task: str) -> str:
    """Normalise ``hiddpg/Name-v0``, ``Name-v0`` or ``Name`` to ``Name``; error if unknown."""
    name = task
    if name.startswith(NAMESPACE + "/"):
        name = name[len(NAMESPACE) + 1:]
    if name.endswith("-" + VERSION):
        name = name[: -len(VERSION) - 1]
    if name not in TASKS:
        raise ValueError(
            f"unknown task {task!r}; known tasks: {[t.env_id for t in TASKS.values()]}"
        )
    return name


def make(task: str, **overrides: Any) -> tuple[Environment, Any]:
    """Build a task's functional core and its params (spec defaults, then ``overrides``)."""
    env = TASKS[task_name(task)].load()()
    return env, env.default_params(**overrides)

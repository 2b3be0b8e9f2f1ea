"""Pure-JAX environments (PuckWorld, the six-muscle arm) and their Gymnasium adapters."""

from hiddpg.envs.base import Environment, GoalSpace, StepResult
from hiddpg.envs.registry import (
    TASKS,
    TaskSpec,
    make,
    register_task,
    task_name,
    unregister_task,
)

__all__ = ["Environment", "GoalSpace", "StepResult", "TASKS", "TaskSpec", "make",
           "register_task", "task_name", "unregister_task"]

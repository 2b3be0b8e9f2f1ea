"""Pure-JAX environments (PuckWorld, the six-muscle arm) and their Gymnasium adapters."""

from hiddpg.envs.base import Environment, GoalSpace, StepResult
from hiddpg.envs.registry import TASKS, make, task_name

__all__ = ["Environment", "GoalSpace", "StepResult", "TASKS", "make", "task_name"]

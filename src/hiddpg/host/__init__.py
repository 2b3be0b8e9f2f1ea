"""The host-loop engine: HI-DDPG, h-DDPG and DDPG on any Gymnasium environment.

The agents and their jitted act and learn steps are the JAX engine's; only the environment
steps in Python, one Gymnasium environment per seed (:mod:`hiddpg.host.loop`). A task is named
``gym:<Gymnasium id or registered name>`` (:mod:`hiddpg.host.task`); the run loop
(:mod:`hiddpg.runner`) trains it through :class:`HostTrainer`, which
:func:`hiddpg.train.make_trainer` builds for such a task::

    from hiddpg.host import register_gym_task
    register_gym_task("Reacher-v5", goal={8: (-0.3, 0.3), 9: (-0.3, 0.3)})
    config = TrainConfig(algo="hi-ddpg", task="gym:Reacher-v5", agent=HIDDPGConfig(), ...)

The declarations (:mod:`hiddpg.host.task`) load without Gymnasium; :class:`HostTrainer`,
:class:`HostEnv` and :func:`make_host_env` import it when first asked for.
"""

from __future__ import annotations

from typing import Any

from hiddpg.host.task import (
    GYM_TASKS,
    PREFIX,
    GymTask,
    gym_task,
    is_gym_task,
    register_gym_task,
    unregister_gym_task,
)

_LAZY = {"HostTrainer": "hiddpg.host.trainer", "HostEnv": "hiddpg.host.env",
         "make_host_env": "hiddpg.host.env"}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = ["GYM_TASKS", "PREFIX", "GymTask", "HostEnv", "HostTrainer", "gym_task",
           "is_gym_task", "make_host_env", "register_gym_task", "unregister_gym_task"]

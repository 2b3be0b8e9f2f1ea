"""The algorithm registry: each algorithm declares its config class, its agent factory and its
presets in one place (:data:`REGISTRY`); ``make_agent``, ``make_config`` and the CLI look here.

Factories, presets and ``finish`` hooks may be given as ``"module:function"`` strings, imported
on first use, so this module loads nothing but the configs.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from typing import Any

from hiddpg.configs.ddpg import DDPGConfig
from hiddpg.configs.h_ddpg import HDDPGConfig
from hiddpg.configs.hi_ddpg import HIDDPGConfig
from hiddpg.envs.base import GoalSpace
from hiddpg.envs.registry import resolve


@dataclasses.dataclass(frozen=True, eq=False)
class Algorithm:
    """One algorithm: ``factory(config, env) -> agent``; ``presets[name](task) -> config`` for
    a registered task name; ``finish(train_config, sets) -> train_config`` after ``--set``."""

    name: str
    config: type
    factory: Callable[[Any, Any], Any] | str
    presets: Mapping[str, Callable[[str], Any] | str]
    summary: str = ""
    finish: Callable[[Any, Any], Any] | str | None = None

    def make(self, config: Any, env: Any) -> Any:
        """The agent for ``env``; ``TypeError`` if ``config`` is not this algorithm's."""
        if not isinstance(config, self.config):
            raise TypeError(f"algorithm {self.name!r} needs a {self.config.__name__}, got "
                            f"{type(config).__name__}")
        return resolve(self.factory)(config, env)

    def preset(self, preset: str, task: str) -> Any:
        """The agent config of ``preset`` for the registered task ``task``."""
        if preset not in self.presets:
            raise ValueError(f"algorithm {self.name!r} has no preset {preset!r}; choose one of "
                             f"{list(self.presets)}")
        return resolve(self.presets[preset])(task)

    def finished(self, train_config: Any, sets: Any) -> Any:
        """``train_config`` after this algorithm's ``finish`` hook (if any)."""
        return train_config if self.finish is None else resolve(self.finish)(train_config, sets)


REGISTRY: dict[str, Algorithm] = {}


def register_algorithm(algorithm: Algorithm) -> Algorithm:
    """Add ``algorithm``; a name taken by a different declaration is refused."""
    old = REGISTRY.get(algorithm.name)
    if old is not None and old is not algorithm:
        raise ValueError(f"algorithm {algorithm.name!r} is already registered "
                         f"(config {old.config.__name__}); choose another name")
    REGISTRY[algorithm.name] = algorithm
    return algorithm


def get_algorithm(name: str) -> Algorithm:
    """The registered algorithm ``name``; ``ValueError`` listing the known ones."""
    if name not in REGISTRY:
        raise ValueError(f"unknown algorithm {name!r}; choose one of {list(REGISTRY)}")
    return REGISTRY[name]


def algorithm_names() -> tuple[str, ...]:
    """Every registered algorithm, in registration order."""
    return tuple(REGISTRY)


def names_with_config(cls: type) -> tuple[str, ...]:
    """The algorithms whose config is ``cls`` (e.g. both HI-DDPG variants)."""
    return tuple(n for n, a in REGISTRY.items() if a.config is cls)


def needs_goal_space(algo: str, env: Any) -> None:
    """``ValueError`` naming ``env``'s class unless it declares a :class:`GoalSpace`."""
    space = getattr(env, "goal_space", None)
    if not isinstance(space, GoalSpace):
        raise ValueError(f"{algo} needs a goal space: {type(env).__name__}.goal_space is "
                         f"{space!r}; declare goal_space = GoalSpace(indices, low, high) on the "
                         "environment class (hiddpg.envs.GoalSpace)")


# -- the built-in algorithms --------------------------------------------------------------------
def _ddpg(config: DDPGConfig, env: Any) -> Any:
    from hiddpg.agents.ddpg import make_ddpg

    return make_ddpg(config, env)


def _hi_ddpg(config: HIDDPGConfig, env: Any) -> Any:
    from hiddpg.agents.hi_ddpg import make_hiddpg

    needs_goal_space("hi-ddpg", env)
    return make_hiddpg(config, env)


def _hi_ddpg_wo_model(config: HIDDPGConfig, env: Any) -> Any:
    """HI-DDPG without the model-based gradient and without training the models."""
    from hiddpg.agents.hi_ddpg import make_hiddpg

    needs_goal_space("hi-ddpg-wo-model", env)
    return make_hiddpg(dataclasses.replace(config, model_weight=0.0, use_model=False), env)


def _h_ddpg(config: HDDPGConfig, env: Any) -> Any:
    """h-DDPG with the skills ``env``'s task declares."""
    from hiddpg.agents.h_ddpg import HDDPG
    from hiddpg.agents.skills import task_skills

    return HDDPG(config, env, task_skills(env, config))


def _presets(stem: str) -> dict[str, str]:
    return {"paper": f"hiddpg.presets:{stem}_paper",
            "paper+": f"hiddpg.variants:{stem}_paper_plus",
            "quick": f"hiddpg.presets:{stem}_quick"}


for _algorithm in (
    Algorithm("ddpg", DDPGConfig, _ddpg, _presets("ddpg"), "flat DDPG"),
    Algorithm("hi-ddpg", HIDDPGConfig, _hi_ddpg, _presets("hi_ddpg"),
              "HI-DDPG: goals and durations above a goal-reaching DDPG",
              "hiddpg.presets:hi_ddpg_finish"),
    Algorithm("hi-ddpg-wo-model", HIDDPGConfig, _hi_ddpg_wo_model, _presets("hi_ddpg_wo_model"),
              "HI-DDPG without the model-based gradient", "hiddpg.presets:hi_ddpg_finish"),
    Algorithm("h-ddpg", HDDPGConfig, _h_ddpg, _presets("h_ddpg"),
              "h-DDPG: a meta-critic choosing among the task's skills every step",
              "hiddpg.presets:h_ddpg_finish"),
):
    register_algorithm(_algorithm)

"""Typed, frozen, validated configs for every agent and for training runs.

Every default is the spec's (``shared/spec/algorithms.md``); tags in the field comments say
where a value comes from: [paper], [source] or [decision]. Configs validate on construction and
name the field, the bad value and what is allowed. Presets (``paper``, ``quick``) live in
:mod:`hiddpg.presets`; ``--set key=value`` overrides are applied by :func:`apply_overrides`.

[decision] marks a value of ours where the paper is silent; docs/deviations.md (each with the
paper's value and why) lists them.
"""

from hiddpg.configs.choice import CHOICES, ActorChoice, CriticDurations, HoldChoice
from hiddpg.configs.ddpg import DDPGConfig, LevelConfig, NoiseConfig
from hiddpg.configs.h_ddpg import HDDPGConfig, MetaCriticConfig
from hiddpg.configs.hi_ddpg import HIDDPGConfig
from hiddpg.configs.parts import (
    ActionHindsight,
    EagerHighLevel,
    GoalHindsight,
    HuberLoss,
    RestTerm,
)
from hiddpg.configs.run import (
    AgentConfig,
    TrainConfig,
    from_dict,
    register_config_type,
    to_dict,
)


def __getattr__(name: str):
    """``ALGORITHMS`` and ``HI_DDPG_ALGORITHMS``, derived from :mod:`hiddpg.algorithms`."""
    if name in ("ALGORITHMS", "HI_DDPG_ALGORITHMS"):
        from hiddpg.configs import run

        return getattr(run, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = ["ALGORITHMS", "CHOICES", "HI_DDPG_ALGORITHMS", "ActionHindsight", "ActorChoice",
           "AgentConfig", "CriticDurations", "DDPGConfig", "EagerHighLevel", "GoalHindsight",
           "HDDPGConfig", "HIDDPGConfig", "HoldChoice", "HuberLoss", "LevelConfig",
           "MetaCriticConfig", "NoiseConfig", "RestTerm", "TrainConfig", "from_dict",
           "register_config_type", "to_dict"]

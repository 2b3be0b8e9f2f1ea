"""Typed, frozen, validated configs for every agent and for training runs.

Every default is the spec's (``shared/spec/algorithms.md``); tags in the field comments say
where a value comes from: [paper], [source] or [decision]. Configs validate on construction and
name the field, the bad value and what is allowed. Presets (``paper``, ``quick``) live in
:mod:`hiddpg.presets`; ``--set key=value`` overrides are applied by :func:`apply_overrides`.
"""

from hiddpg.configs.ddpg import DDPGConfig, LevelConfig, NoiseConfig
from hiddpg.configs.h_ddpg import HDDPGConfig
from hiddpg.configs.hi_ddpg import HIDDPGConfig
from hiddpg.configs.run import (
    ALGORITHMS,
    HI_DDPG_ALGORITHMS,
    AgentConfig,
    TrainConfig,
    from_dict,
    register_config_type,
    to_dict,
)

__all__ = ["ALGORITHMS", "HI_DDPG_ALGORITHMS", "AgentConfig", "DDPGConfig", "HDDPGConfig",
           "HIDDPGConfig", "LevelConfig", "NoiseConfig", "TrainConfig", "from_dict",
           "register_config_type", "to_dict"]

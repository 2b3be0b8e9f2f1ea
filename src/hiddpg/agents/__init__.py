"""Agents: flat DDPG, HI-DDPG (with and without the model-based gradient) and h-DDPG.

All are built from the shared DDPG block (:mod:`hiddpg.agents.block`) and follow the protocol of
:mod:`hiddpg.agents.base`.
"""

from __future__ import annotations

import dataclasses
from typing import Any

from hiddpg.configs import ALGORITHMS, HI_DDPG_ALGORITHMS, DDPGConfig, HIDDPGConfig


def make_agent(algo: str, config: Any, env: Any) -> Any:
    """The agent ``algo`` (one of :data:`hiddpg.configs.ALGORITHMS`) for ``env``."""
    if algo == "ddpg":
        from hiddpg.agents.ddpg import make_ddpg

        _expect(algo, config, DDPGConfig)
        return make_ddpg(config, env)
    if algo in HI_DDPG_ALGORITHMS:
        from hiddpg.agents.hi_ddpg import make_hiddpg

        _expect(algo, config, HIDDPGConfig)
        if algo == "hi-ddpg-wo-model":
            config = dataclasses.replace(config, model_weight=0.0, use_model=False)
        return make_hiddpg(config, env)
    if algo == "h-ddpg":
        from hiddpg.agents.h_ddpg import make_hddpg

        return make_hddpg(config, env)
    raise ValueError(f"unknown algorithm {algo!r}; choose one of {list(ALGORITHMS)}")


def _expect(algo: str, config: Any, cls: type) -> None:
    if not isinstance(config, cls):
        raise TypeError(f"algorithm {algo!r} needs a {cls.__name__}, got {type(config).__name__}")

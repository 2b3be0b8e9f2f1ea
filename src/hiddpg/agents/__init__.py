"""Agents: flat DDPG, HI-DDPG (with and without the model-based gradient) and h-DDPG.

All are built from the shared DDPG block (:mod:`hiddpg.agents.block`) and follow the protocol of
:mod:`hiddpg.agents.base`; :mod:`hiddpg.algorithms` declares which factory builds which.
"""

from __future__ import annotations

from typing import Any

from hiddpg.algorithms import get_algorithm


def make_agent(algo: str, config: Any, env: Any) -> Any:
    """The agent ``algo`` (a name of :mod:`hiddpg.algorithms`' registry) for ``env``."""
    return get_algorithm(algo).make(config, env)

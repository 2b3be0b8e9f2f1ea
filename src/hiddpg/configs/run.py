"""A training run's config (:class:`TrainConfig`) and the configs' JSON form (:func:`to_dict`,
:func:`from_dict`)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

from hiddpg.configs.checks import positive
from hiddpg.configs.choice import CHOICES
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

AgentConfig = DDPGConfig | HIDDPGConfig | HDDPGConfig


@dataclass(frozen=True)
class TrainConfig:
    """A training run: which algorithm on which task, for how long, with what agent config.

    The seeds are not part of the config: one config is trained on many seeds at once.
    """

    algo: str
    """A registered algorithm (:mod:`hiddpg.algorithms`)."""
    task: str
    """A registered task, e.g. ``hiddpg/PuckTrajectory2-v0``."""
    agent: Any
    """The algorithm's config (:class:`DDPGConfig`, :class:`HIDDPGConfig`, ...)."""
    episodes: int = 1000
    """Training episodes per seed."""
    eval_every: int = 10
    """Run a noise-free evaluation episode every this many episodes (and at the end)."""
    chunk_episodes: int = 50
    """Episodes per jitted chunk; a checkpoint is written after every chunk."""
    env: tuple[tuple[str, Any], ...] = ()
    """Environment parameter overrides, as (name, value) pairs."""
    preset: str = "paper"
    """The preset this config was built from (recorded for provenance)."""

    def __post_init__(self) -> None:
        from hiddpg.algorithms import algorithm_names

        if self.algo not in algorithm_names():
            raise ValueError(f"algo={self.algo!r} is unknown; choose one of "
                             f"{list(algorithm_names())}")
        positive(self, "episodes", "eval_every", "chunk_episodes")
        for name in ("episodes", "eval_every", "chunk_episodes"):
            if not isinstance(getattr(self, name), int):
                raise ValueError(f"TrainConfig.{name}={getattr(self, name)!r} must be an int")

    @property
    def env_overrides(self) -> dict[str, Any]:
        return dict(self.env)


def __getattr__(name: str) -> Any:
    """``ALGORITHMS`` (every registered algorithm) and ``HI_DDPG_ALGORITHMS`` (those with a
    :class:`HIDDPGConfig`), read from :mod:`hiddpg.algorithms` when asked for."""
    if name in ("ALGORITHMS", "HI_DDPG_ALGORITHMS"):
        from hiddpg import algorithms

        return (algorithms.algorithm_names() if name == "ALGORITHMS"
                else algorithms.names_with_config(HIDDPGConfig))
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def to_dict(cfg: Any) -> dict[str, Any]:
    """A JSON-ready dict of a (nested) config, with a ``_type`` tag for each dataclass."""
    if dataclasses.is_dataclass(cfg):
        out = {"_type": type(cfg).__name__}
        for f in dataclasses.fields(cfg):
            out[f.name] = to_dict(getattr(cfg, f.name))
        return out
    if isinstance(cfg, tuple):
        return [to_dict(v) for v in cfg]
    return cfg


_TYPES = {c.__name__: c for c in (NoiseConfig, DDPGConfig, LevelConfig, HIDDPGConfig,
                                   HDDPGConfig, MetaCriticConfig, TrainConfig, HuberLoss,
                                   GoalHindsight, ActionHindsight, RestTerm, EagerHighLevel,
                                   *CHOICES)}


def register_config_type(cls: type) -> type:
    """Make a config dataclass known to :func:`from_dict` (agents added later use this)."""
    _TYPES[cls.__name__] = cls
    return cls


def from_dict(data: Any) -> Any:
    """Inverse of :func:`to_dict`."""
    if isinstance(data, dict) and "_type" in data:
        if data["_type"] not in _TYPES:
            raise ValueError(f"config type {data['_type']!r} is unknown to this version of "
                             f"hiddpg; known: {sorted(_TYPES)}")
        cls = _TYPES[data["_type"]]
        kwargs = {k: from_dict(v) for k, v in data.items() if k != "_type"}
        names = {f.name for f in dataclasses.fields(cls) if f.init}
        unknown = sorted(set(kwargs) - names)
        if unknown:
            raise ValueError(f"{cls.__name__} has no field(s) {unknown} (a config written by "
                             f"another version of hiddpg?); its fields: {sorted(names)}")
        for f in dataclasses.fields(cls):
            if f.name in kwargs and isinstance(kwargs[f.name], list):
                kwargs[f.name] = _tuplify(kwargs[f.name])
        return cls(**kwargs)
    return data


def _tuplify(v: Any) -> Any:
    return tuple(_tuplify(x) for x in v) if isinstance(v, list) else v

"""How HI-DDPG's high level chooses its goal and duration at a switch: the paper's actor, or one
of our two choices that let the critic decide. ``HIDDPGConfig.choice`` holds one of them; the
implementations are :mod:`hiddpg.agents.choice`, :mod:`hiddpg.agents.hold` and
:mod:`hiddpg.agents.durations`.

[decision] marks a value of ours where the paper is silent; docs/deviations.md (each with the
paper's value and why) lists them."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from hiddpg.configs.checks import unit


@dataclass(frozen=True)
class ActorChoice:
    """The high level's actor outputs goal and duration ``(g, T)`` together, explored by OU
    noise [paper, Alg. 1 line 7]."""

    kind: ClassVar[str] = "actor"


@dataclass(frozen=True)
class HoldChoice:
    """The actor's ``(g, T)``, or the same goal held to the episode's end where the high critic
    values that more; the high level sees the fraction of the episode left [decision]."""

    kind: ClassVar[str] = "hold"
    explore: float = 0.1
    """Probability that a training switch holds its goal to the end."""

    def __post_init__(self) -> None:
        unit(self, "explore")


@dataclass(frozen=True)
class CriticDurations:
    """The duration is a discrete choice: the actor maps ``(s, T)`` to a goal and the critic
    picks the integer ``T`` whose goal it values most (P-DQN-like); the high level sees the
    fraction of the episode left and has no dynamics model (it would not see ``T``)
    [decision]."""

    kind: ClassVar[str] = "critic-durations"
    explore: float = 0.5
    """Probability that a training switch draws its duration uniformly."""

    def __post_init__(self) -> None:
        unit(self, "explore")


CHOICES = (ActorChoice, HoldChoice, CriticDurations)
"""Every high-level choice, selected in ``--set agent.choice=KIND`` by its ``kind``."""

HighChoiceConfig = ActorChoice | HoldChoice | CriticDurations

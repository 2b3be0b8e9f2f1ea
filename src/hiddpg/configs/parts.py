"""Configs of the named additions to the paper's HI-DDPG. Each one is off (``None``) in the
paper's configuration and switched on by giving its config; each has one module under
:mod:`hiddpg.agents` and one seam where it plugs in.

[decision] marks a value of ours where the paper is silent; docs/deviations.md (each with the
paper's value and why) lists them."""

from __future__ import annotations

from dataclasses import dataclass

from hiddpg.configs.checks import nonnegative, positive, unit


@dataclass(frozen=True)
class HuberLoss:
    """A level's critic minimises the Huber loss of its TD error, squared within ``delta`` of
    the target and linear beyond (:mod:`hiddpg.agents.huber`) [decision; the paper's loss is
    the squared error]."""

    delta: float = 10.0
    """``δ`` of the Huber loss."""
    late_delta: float = 0.0
    """``δ`` from episode ``late_episode`` on (0: ``delta`` throughout)."""
    late_episode: int = 0
    """The episode (counted from 0, pre-training included) from which ``late_delta`` applies."""

    def __post_init__(self) -> None:
        positive(self, "delta")
        nonnegative(self, "late_delta", hint="0: delta throughout")
        if self.late_delta > 0 and not (isinstance(self.late_episode, int)
                                        and self.late_episode >= 1):
            raise ValueError(f"HuberLoss.late_episode={self.late_episode!r} must be an int "
                             ">= 1 when late_delta is set")


@dataclass(frozen=True)
class GoalHindsight:
    """The low level learns from hindsight goals: a fraction of each minibatch has its goal
    replaced by one reached later in the same episode, the reward recomputed (HER's "future"
    strategy; :mod:`hiddpg.agents.hindsight`) [decision]."""

    fraction: float = 0.8
    """Probability that a sampled transition gets a hindsight goal."""

    def __post_init__(self) -> None:
        unit(self, "fraction")


@dataclass(frozen=True)
class ActionHindsight:
    """A segment enters ``D_H`` with the goal its low level reached in place of the goal set
    (HAC's hindsight actions); a segment that ends the episode by termination keeps the goal
    set, so a collision stays charged to the goal that led to it
    (:mod:`hiddpg.agents.hindsight`) [decision]."""

    probability: float = 1.0
    """Probability that a segment is stored with the goal reached."""

    def __post_init__(self) -> None:
        unit(self, "probability")


@dataclass(frozen=True)
class EagerHighLevel:
    """The high level learns from more than Alg. 1 gives it: an update at every environment
    step instead of one per segment, and the pre-training's segments in ``D_H``
    (:mod:`hiddpg.agents.eager`) [decision]."""

    every_step: bool = True
    """One high-level update at every environment step (Alg. 1: at every segment end)."""
    pretraining_segments: bool = True
    """``D_H`` also stores the low-level pre-training's segments (random goals and durations,
    their true rewards and end states); the high level still does not learn in pre-training."""


@dataclass(frozen=True)
class RestTerm:
    """The intrinsic reward also counts the goal state's other entries (the velocities, 0 in
    the paper's goal ``[gx, gy, 0, 0]``), weighted by ``weight``, so the low level learns to
    arrive at rest (:mod:`hiddpg.agents.intrinsic`) [decision]."""

    weight: float = 0.3
    """``w`` in ``r_int = -|(P (s' - g), w R s')|``."""

    def __post_init__(self) -> None:
        nonnegative(self, "weight")

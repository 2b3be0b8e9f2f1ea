"""The config of HI-DDPG (spec §2-3): its two levels, the hierarchy's paper values, and the
named additions, each off (``None``, or the paper's :class:`ActorChoice`) unless given.

[decision] marks a value of ours where the paper is silent; docs/deviations.md (each with the
paper's value and why) lists them."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from hiddpg.configs.checks import positive, unit
from hiddpg.configs.choice import ActorChoice, CriticDurations, HighChoiceConfig
from hiddpg.configs.ddpg import LevelConfig
from hiddpg.configs.parts import ActionHindsight, EagerHighLevel, GoalHindsight, RestTerm


def _high_default() -> LevelConfig:
    return LevelConfig(lr=2e-5, gamma=0.99, buffer_size=100_000)


def _low_default() -> LevelConfig:
    return LevelConfig(lr=2e-4, gamma=0.95, buffer_size=10_000)


@dataclass(frozen=True)
class HIDDPGConfig:
    """HI-DDPG (spec §2-3). ``model_weight = 0`` with ``use_model = False`` is HI-DDPG-wo-model."""

    high: LevelConfig = field(default_factory=_high_default)
    low: LevelConfig = field(default_factory=_low_default)
    duration_min: float = 1.0
    """Smallest duration T the high level can choose: puck 1, arm 2 [decision]."""
    duration_max: float = 30.0
    """Largest duration T: puck 30, arm 40 [decision]."""
    switch_cost: float = 10.0
    """Subtracted from f for every goal after the first: 10 on puck trajectories [paper]."""
    model_weight: float = 1.0
    """λ_model, weight of the model-based gradient (eqs. 6-7) [decision]."""
    use_model: bool = True
    """Train the dynamics models (False for HI-DDPG-wo-model)."""
    model_masked: bool = True
    """The model-based term is multiplied by ``1 - terminated`` of each sampled transition:
    where the episode ended there is no successor value to climb [decision; spec §3]."""
    pretrain_episodes: int = 0
    """Episodes of low-level pre-training with random goals: arm 1000, puck 0 [paper]."""
    learning_starts: int = 1000
    """Environment steps with random goals and random actions before learning [decision]."""
    high_learning_starts: int = 64
    """Segments stored in D_H before the high level starts learning [decision]."""
    lr_decay: float = 1.0
    """Learning rates multiplied by this every ``lr_decay_every`` episodes: arm 0.99 [paper]."""
    lr_decay_every: int = 50
    """Episodes between two learning-rate decays [paper]."""
    eager_high: EagerHighLevel | None = None
    """More high-level updates and data than Alg. 1's [decision; None: one update per
    segment end, ``D_H`` empty after pre-training, the paper's]."""
    choice: HighChoiceConfig = field(default_factory=ActorChoice)
    """How the high level chooses ``(g, T)``: the actor [paper], or the critic's hold or
    duration choice (:mod:`hiddpg.configs.choice`) [decision]."""
    low_hindsight: GoalHindsight | None = None
    """Hindsight goals for the low level [decision; None: the goals set]."""
    high_hindsight: ActionHindsight | None = None
    """Hindsight actions for the high level [decision; None: the goals set]."""
    rest_term: RestTerm | None = None
    """The intrinsic reward's rest term [decision; None: the goal entries only]."""

    def __post_init__(self) -> None:
        positive(self, "duration_min", "duration_max", "lr_decay_every")
        if self.duration_min > self.duration_max:
            raise ValueError(
                f"HIDDPGConfig.duration_min={self.duration_min} (T_min) is larger than "
                f"duration_max={self.duration_max} (T_max); it must be <= duration_max"
            )
        if self.model_weight < 0 or not math.isfinite(self.model_weight):
            raise ValueError(f"HIDDPGConfig.model_weight={self.model_weight} must be >= 0")
        if self.model_weight > 0 and not self.use_model:
            raise ValueError(
                f"HIDDPGConfig.model_weight={self.model_weight} needs use_model=True "
                "(set model_weight=0 for HI-DDPG-wo-model)"
            )
        for name in ("pretrain_episodes", "learning_starts", "high_learning_starts"):
            if getattr(self, name) < 0:
                raise ValueError(f"HIDDPGConfig.{name}={getattr(self, name)} must be >= 0")
        if (isinstance(self.choice, CriticDurations)
                and math.floor(self.duration_max) - math.ceil(self.duration_min) < 1):
            raise ValueError(
                f"HIDDPGConfig.choice=CriticDurations needs at least two integer durations in "
                f"[duration_min, duration_max] = [{self.duration_min}, {self.duration_max}]")
        if not math.isfinite(self.switch_cost):
            raise ValueError(f"HIDDPGConfig.switch_cost={self.switch_cost} must be finite")
        unit(self, "lr_decay")

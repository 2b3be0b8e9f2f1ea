"""The config of h-DDPG, the paper's hierarchical baseline (spec §4).

[decision] marks a value of ours where the paper is silent; docs/deviations.md (each with the
paper's value and why) lists them."""

from __future__ import annotations

from dataclasses import dataclass, field

from hiddpg.configs.checks import positive, unit
from hiddpg.configs.ddpg import DDPGConfig, ReplayLearnerConfig


@dataclass(frozen=True)
class MetaCriticConfig(ReplayLearnerConfig):
    """h-DDPG's meta-critic, trained like a DQN on the environment reward (spec §4)."""

    hidden: tuple[int, ...] = (300, 300)
    """Hidden sizes of the meta-critic MLP [decision: those of the skills]."""
    gamma: float = 0.99
    """Discount of the DQN target [paper]."""
    tau: float = 0.01
    """Polyak rate of the target network, applied every update [decision]."""
    lr: float = 1e-3
    """Adam learning rate [decision]."""

    def __post_init__(self) -> None:
        super().__post_init__()
        positive(self, "lr")


def _skill_default() -> DDPGConfig:
    return DDPGConfig(gamma=0.99)


@dataclass(frozen=True)
class HDDPGConfig:
    """h-DDPG (Yang et al. 2018 as adapted in paper §III-C; spec §4): K = 4 basic skills, each
    a DDPG actor–critic with a built-in movement pattern, chosen every step by ε-greedy on a
    meta-critic ``Q_meta(s) ∈ R^K`` trained like a DQN on the environment reward.

    The number of skills K = 4 [paper] is the number of movement patterns of the task family
    (:mod:`hiddpg.agents.skills`)."""

    skill: DDPGConfig = field(default_factory=_skill_default)
    """Every skill's DDPG (spec §1): hidden sizes, learning rates (and their decay), γ = 0.99,
    τ, batch, buffer capacity *per skill*, OU noise on the skill's unit output, action_l2.
    Its ``learning_starts`` is the run's random phase: environment steps with uniformly random
    skills and skill outputs before anything learns [decision]."""
    meta: MetaCriticConfig = field(default_factory=MetaCriticConfig)
    """The meta-critic ``Q_meta(s) ∈ R^K`` and its replay of ``(s, k, r, s', terminated)``."""
    epsilon_start: float = 1.0
    """ε of the ε-greedy skill choice at the first episode [decision]."""
    epsilon_end: float = 0.1
    """ε after ``epsilon_decay_episodes`` episodes and from then on [decision]."""
    epsilon_fraction: float = 0.2
    """Fraction of the training episodes over which ε decays linearly [decision]; presets
    turn it into ``epsilon_decay_episodes`` from the run's budget."""
    epsilon_decay_episodes: int = 200
    """Episodes over which ε falls linearly from ``epsilon_start`` to ``epsilon_end`` (set by
    the presets to ``epsilon_fraction`` × the training episodes)."""
    puck_max_speed: float = 3.0
    """PuckWorld skills: the speed ``v_max`` their unit output's top maps to (the reference
    trajectories reach 1.6-2.9) [decision]."""

    def __post_init__(self) -> None:
        positive(self, "epsilon_decay_episodes", "puck_max_speed")
        unit(self, "epsilon_start", "epsilon_end")
        unit(self, "epsilon_fraction", closed=False)
        if self.epsilon_end > self.epsilon_start:
            raise ValueError(
                f"HDDPGConfig.epsilon_end={self.epsilon_end} is larger than epsilon_start="
                f"{self.epsilon_start}; it must be <= epsilon_start"
            )
        if not isinstance(self.epsilon_decay_episodes, int):
            raise ValueError(f"HDDPGConfig.epsilon_decay_episodes="
                             f"{self.epsilon_decay_episodes!r} must be an int >= 1")

"""The configs of one DDPG actor-critic: its exploration noise (:class:`NoiseConfig`), flat
DDPG (:class:`DDPGConfig`) and one level of HI-DDPG (:class:`LevelConfig`).

[decision] marks a value of ours where the paper is silent; docs/deviations.md (each with the
paper's value and why) lists them."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

from hiddpg.configs.checks import buffer, hidden, positive, unit
from hiddpg.configs.parts import HuberLoss


@dataclass(frozen=True)
class NoiseConfig:
    """Exploration noise added to an actor's output in its normalised ([-1, 1]) box."""

    kind: Literal["ou", "gaussian"] = "ou"
    """Ornstein-Uhlenbeck (reset every episode) [paper] or i.i.d. Gaussian [decision]."""
    theta: float = 0.05
    """OU mean reversion α [paper]."""
    sigma: float = 0.1
    """Noise scale: 0.1 on the puck, 0.15 on the arm [paper]."""
    final_sigma: float = -1.0
    """Noise scale reached after ``decay_episodes`` episodes, linearly from ``sigma``; negative
    keeps ``sigma`` throughout [paper: constant]."""
    decay_episodes: int = 1
    """Episodes over which the scale goes from ``sigma`` to ``final_sigma``."""

    def __post_init__(self) -> None:
        if self.kind not in ("ou", "gaussian"):
            raise ValueError(f"NoiseConfig.kind={self.kind!r} must be 'ou' or 'gaussian'")
        unit(self, "theta")
        if not self.sigma >= 0:
            raise ValueError(f"NoiseConfig.sigma={self.sigma!r} must be >= 0")
        if not math.isfinite(self.final_sigma):
            raise ValueError(f"NoiseConfig.final_sigma={self.final_sigma!r} must be a number: "
                             ">= 0 to decay to it, negative for a constant sigma")
        if self.decay_episodes < 1:
            raise ValueError(f"NoiseConfig.decay_episodes={self.decay_episodes!r} must be >= 1")

    @property
    def decays(self) -> bool:
        return self.final_sigma >= 0


@dataclass(frozen=True)
class ReplayLearnerConfig:
    """A value learner with target networks and a replay buffer (the DDPG blocks, h-DDPG's
    meta-critic)."""

    hidden: tuple[int, ...] = (300, 300)
    """Hidden layer sizes; arm tasks add a third 300 layer [paper]."""
    gamma: float = 0.99
    """Discount."""
    tau: float = 0.001
    """Polyak rate of the target networks [decision: DDPG paper]."""
    batch_size: int = 64
    """Minibatch size [decision: DDPG paper]."""
    buffer_size: int = 100_000
    """Replay capacity."""

    def __post_init__(self) -> None:
        hidden(self)
        positive(self, "batch_size", "buffer_size")
        unit(self, "gamma", "tau")
        buffer(self)


@dataclass(frozen=True)
class ActorCriticConfig(ReplayLearnerConfig):
    """What every DDPG actor-critic has (spec §1): the learner's networks, discount, targets and
    replay, its exploration noise and the actor's stabilisers."""

    noise: NoiseConfig = field(default_factory=NoiseConfig)
    """Exploration noise on the actor's normalised outputs [paper]."""
    invert_gradients: bool = False
    """Damp the actor's action gradient near the bounds of its box so that ``tanh`` does not
    saturate (Hausknecht & Stone 2016) [decision; False = the paper's plain DPG]."""
    action_l2: float = 0.0
    """Penalty weight on the squared unit action in the actor's objective (Andrychowicz et
    al. 2017) [decision; 0 = the paper's plain DPG]."""
    end_is_terminal: bool = False
    """No bootstrap at the end of any episode, time limit included (the paper's arm rule,
    §III-B) [decision per task; False: time-limit ends bootstrap, spec §3]."""
    actor_output: Literal["tanh", "linear"] = "tanh"
    """The actor's output layer: ``tanh`` into the unit box [spec §1], or ``linear``, clipped
    to the box wherever the action is used and differentiated unclipped in the policy
    gradient (the paper, §II-D: "the output units have linear activation")."""

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.actor_output not in ("tanh", "linear"):
            raise ValueError(f"{type(self).__name__}.actor_output={self.actor_output!r} must be "
                             "'tanh' or 'linear'")


@dataclass(frozen=True)
class DDPGConfig(ActorCriticConfig):
    """Flat DDPG (the paper's "plain DDPG"), built on the shared DDPG block (spec §1)."""

    gamma: float = 0.99
    """Discount [decision]."""
    buffer_size: int = 100_000
    """Replay capacity [decision]."""
    actor_lr: float = 1e-4
    """Adam learning rate of the actor [decision: DDPG paper]."""
    critic_lr: float = 1e-3
    """Adam learning rate of the critic [decision: DDPG paper]."""
    learning_starts: int = 1000
    """Environment steps of uniformly random actions before learning starts [decision]."""
    lr_decay: float = 1.0
    """Learning rates are multiplied by this every ``lr_decay_every`` episodes (1 = off)."""
    lr_decay_every: int = 50
    """Episodes between two learning-rate decays."""

    def __post_init__(self) -> None:
        super().__post_init__()
        positive(self, "actor_lr", "critic_lr", "lr_decay_every")
        unit(self, "lr_decay")
        if self.learning_starts < 0:
            raise ValueError(f"DDPGConfig.learning_starts={self.learning_starts} must be >= 0")


@dataclass(frozen=True)
class LevelConfig(ActorCriticConfig):
    """One level (high or low) of HI-DDPG: a DDPG block plus its dynamics model."""

    gamma: float = 0.95
    """Discount: 0.99 high level, 0.95 low level [paper]."""
    buffer_size: int = 10_000
    """Replay capacity: puck D_H = 1e5, D_L = 1e4; arm 1e6 / 1e5 [paper]."""
    lr: float = 2e-4
    """Adam learning rate shared by the level's actor, critic and model [paper]."""
    huber: HuberLoss | None = None
    """The critic's loss: the squared TD error (None) [paper], or the Huber loss
    (:class:`~hiddpg.configs.parts.HuberLoss`) [decision]."""
    env_terminal: bool = True
    """An environment termination (a collision) ends the level's value (spec §3); False
    bootstraps through it [decision: the low level on the terminating tasks, whose reward is
    intrinsic only]."""

    def __post_init__(self) -> None:
        super().__post_init__()
        positive(self, "lr")

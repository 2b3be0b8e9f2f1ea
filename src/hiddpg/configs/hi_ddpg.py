"""The config of HI-DDPG (spec §2-3): its two levels and the options of the hierarchy."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

from hiddpg.configs.checks import nonnegative, positive, unit
from hiddpg.configs.ddpg import LevelConfig


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
    intrinsic_squared: bool = False
    """Low-level reward ``-|P (s' - g)|^2`` instead of ``-|P (s' - g)|`` [decision; False = the
    spec's form]. With :attr:`intrinsic_action_cost` it is the stage cost of an LQR problem."""
    intrinsic_action_cost: float = 0.0
    """``w``: the low-level reward also subtracts ``w |a|^2`` of the action given to the
    environment (its normalised box) [decision; 0 = the spec's form]. On the puck,
    ``intrinsic_squared`` with ``w = 3 / 0.95`` (the reference's ``0.03 |F|^2``, ``F = 10 a``,
    over ``γ_L = 0.95`` for the reward's one-step delay) makes the puck's reference controller
    the optimal low-level controller (tested), so the reference goals become the best goals.
    Not in the presets: DDPG's low level did not learn that controller (docs/results.md)."""
    intrinsic_rest_weight: float = 0.0
    """``w``: the low level's distance also counts the goal vector's other entries, weighted
    by ``w``: ``r_int = -|(P (s' - g), w R s')|`` with ``R`` selecting the entries a goal does
    not fix (the velocities: the paper's goal is the state ``[gx, gy, 0, 0]``), so that the
    low level learns to arrive at rest rather than pass through the goal [decision; 0 = the
    spec's form, the goal entries only]."""
    low_hindsight: float = 0.0
    """Fraction of the low level's minibatch whose goal is replaced by one reached later in
    the same episode, with the reward recomputed (hindsight relabelling, the "future"
    strategy of HER; :mod:`hiddpg.agents.hindsight`) [decision; 0 = plain DDPG on the goals
    the high level set]."""
    high_hindsight: float = 0.0
    """Probability that a segment enters ``D_H`` with the goal its low level reached (the
    goal entries of the segment's last state) in place of the goal the high level set:
    the "hindsight action transitions" of hierarchical actor-critic (Levy et al. 2019), so
    that the high critic learns what a goal leads to where the low level really gets
    there. A segment that ends the episode by termination (a collision) keeps the goal set:
    the collision is charged to the goal that led to it (relabelled, a straight path's
    goal went unpunished) [decision; 0 = the goals as set, the paper's]."""
    low_controller: Literal["learned", "reference"] = "learned"
    """``"reference"``: the low level is not learned; the environment's own goal-reaching
    controller acts instead (the puck's LQR reference controller, spec §1.1) — a diagnostic
    that separates what the high level learns from what the low level does [decision;
    "learned" = the paper's method]. It acts noise-free, also in the random phase.
    Environments without a ``reference_controller`` refuse it."""
    high_time_input: bool = False
    """The high level also sees the fraction of the episode left, ``steps_left / horizon``
    (its MDP is then Markov on the time-indexed tasks, where the reward depends on the step)
    [decision; False = the paper's state-only high level]. Pair it with
    ``high.end_is_terminal`` on tasks that end by a time limit."""
    hold_choice: bool = False
    """At a switch the high critic compares the actor's ``(g, T)`` with ``(g, hold to the
    end)`` and takes the better: a non-local step in ``T`` that the policy gradient cannot
    make, since the return jumps by the switch cost only where ``T`` reaches the end
    (docs/results.md) [decision; False = the paper's actor-only choice]. Needs
    ``high_time_input`` to be meaningful past the first segment."""
    hold_explore: float = 0.0
    """Probability that a training switch holds its goal to the end, so that ``D_H`` holds
    such segments from every switch state [decision; 0 = none]."""
    duration_choice: Literal["actor", "argmax"] = "actor"
    """How the high level picks the duration: ``"actor"``, its actor outputs ``(g, T)``
    [paper]; ``"argmax"``, the actor maps ``(s, T)`` to a goal and the critic picks the
    integer ``T`` whose goal it values most (:mod:`hiddpg.agents.durations`) [decision].
    ``"argmax"`` needs ``high_time_input``, no model (``model_weight = 0``, ``use_model =
    False``: the high model does not see ``T``), and no ``hold_choice``/``hold_explore``
    (holding is one of its choices)."""
    duration_explore: float = 0.0
    """Probability that a training switch draws its duration uniformly from the integers in
    ``[T_min, T_max]`` (at most the steps left); with ``"argmax"`` the goal is then the
    actor's for that duration [decision; 0 = none]."""
    model_weight: float = 1.0
    """λ_model, weight of the model-based gradient (eqs. 6-7) [decision]."""
    use_model: bool = True
    """Train the dynamics models (False for HI-DDPG-wo-model)."""
    pretrain_episodes: int = 0
    """Episodes of low-level pre-training with random goals: arm 1000, puck 0 [paper]."""
    pretrain_fills_high_buffer: bool = False
    """Store the pre-training phase's segments (random goals and durations) in ``D_H``, so that
    the high level starts from a broad sample of goal sequences instead of only its own
    [decision; False = D_H starts empty after pre-training]."""
    learning_starts: int = 1000
    """Environment steps with random goals and random actions before learning [decision]."""
    high_learning_starts: int = 64
    """Segments stored in D_H before the high level starts learning [decision]."""
    lr_decay: float = 1.0
    """Learning rates multiplied by this every ``lr_decay_every`` episodes: arm 0.99 [paper]."""
    lr_decay_every: int = 50
    high_update_on: Literal["segment", "step"] = "segment"
    """When the high level learns: at every segment end (Alg. 1 lines 16-20) [paper], or at
    every environment step [decision: under ``vmap`` the masked update is computed every step
    anyway, so ``"step"`` gives ~T times more high-level updates for the same compute]."""

    def __post_init__(self) -> None:
        if self.low_controller not in ("learned", "reference"):
            raise ValueError(f"HIDDPGConfig.low_controller={self.low_controller!r} must be "
                             "'learned' or 'reference'")
        if self.high_update_on not in ("segment", "step"):
            raise ValueError(f"HIDDPGConfig.high_update_on={self.high_update_on!r} must be "
                             "'segment' or 'step'")
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
        nonnegative(self, "intrinsic_action_cost", "intrinsic_rest_weight")
        if not 0.0 <= self.low_hindsight <= 1.0:
            raise ValueError(f"HIDDPGConfig.low_hindsight={self.low_hindsight} must be a "
                             "probability in [0, 1]")
        if not 0.0 <= self.high_hindsight <= 1.0:
            raise ValueError(f"HIDDPGConfig.high_hindsight={self.high_hindsight} must be a "
                             "probability in [0, 1]")
        if not 0.0 <= self.hold_explore <= 1.0:
            raise ValueError(f"HIDDPGConfig.hold_explore={self.hold_explore} must be a "
                             "probability in [0, 1]")
        if self.duration_choice not in ("actor", "argmax"):
            raise ValueError(f"HIDDPGConfig.duration_choice={self.duration_choice!r} must be "
                             "'actor' or 'argmax'")
        if not 0.0 <= self.duration_explore <= 1.0:
            raise ValueError(f"HIDDPGConfig.duration_explore={self.duration_explore} must be "
                             "a probability in [0, 1]")
        if self.low.terminal_head:
            raise ValueError("HIDDPGConfig.low.terminal_head=True: only the high level's "
                             "critic can split off the terminal rewards (the low level's "
                             "reward is intrinsic); set high.terminal_head instead")
        if self.high.terminal_head and self.duration_choice != "actor":
            raise ValueError(f"HIDDPGConfig.high.terminal_head=True needs duration_choice="
                             f"'actor', not {self.duration_choice!r}")
        if self.duration_choice == "argmax":
            clash = [f"{k}={getattr(self, k)}" for k, bad in (
                ("high_time_input", not self.high_time_input),
                ("model_weight", self.model_weight != 0), ("use_model", self.use_model),
                ("hold_choice", self.hold_choice), ("hold_explore", self.hold_explore != 0))
                if bad]
            if clash:
                raise ValueError(
                    f"HIDDPGConfig.duration_choice='argmax' does not work with {', '.join(clash)}"
                    ": it needs high_time_input=True, model_weight=0, use_model=False, "
                    "hold_choice=False and hold_explore=0")
            if math.floor(self.duration_max) - math.ceil(self.duration_min) < 1:
                raise ValueError(
                    f"HIDDPGConfig.duration_choice='argmax' needs at least two integer "
                    f"durations in [duration_min, duration_max] = [{self.duration_min}, "
                    f"{self.duration_max}]")
        if not math.isfinite(self.switch_cost):
            raise ValueError(f"HIDDPGConfig.switch_cost={self.switch_cost} must be finite")
        unit(self, "lr_decay")

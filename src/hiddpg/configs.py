"""Typed, frozen, validated configs for every agent and for training runs.

Every default is the spec's (``shared/spec/algorithms.md``); tags in the field comments say
where a value comes from: [paper], [source] or [decision]. Configs validate on construction and
name the field, the bad value and what is allowed. Presets (``paper``, ``quick``) live in
:mod:`hiddpg.presets`; ``--set key=value`` overrides are applied by :func:`apply_overrides`.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, Literal

ALGORITHMS = ("ddpg", "hi-ddpg", "hi-ddpg-wo-model", "h-ddpg")
HI_DDPG_ALGORITHMS = ("hi-ddpg", "hi-ddpg-wo-model")
"""The algorithms whose agent is :class:`HIDDPGConfig`'s (HI-DDPG with and without model)."""


def _positive(obj: Any, *names: str) -> None:
    for name in names:
        v = getattr(obj, name)
        if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
            raise ValueError(f"{type(obj).__name__}.{name}={v!r} must be a finite number > 0")


def _unit(obj: Any, *names: str, closed: bool = True) -> None:
    for name in names:
        v = getattr(obj, name)
        ok = isinstance(v, int | float) and (0 <= v <= 1 if closed else 0 < v <= 1)
        if not ok:
            rng = "[0, 1]" if closed else "(0, 1]"
            raise ValueError(f"{type(obj).__name__}.{name}={v!r} must lie in {rng}")


def _hidden(obj: Any, name: str = "hidden") -> None:
    h = getattr(obj, name)
    if not h or any(not isinstance(n, int) or n <= 0 for n in h):
        raise ValueError(
            f"{type(obj).__name__}.{name}={h!r} must be a non-empty tuple of positive ints"
        )


def _buffer(obj: Any) -> None:
    if obj.batch_size > obj.buffer_size:
        raise ValueError(
            f"{type(obj).__name__}.batch_size={obj.batch_size} is larger than "
            f"buffer_size={obj.buffer_size}; it must be <= buffer_size"
        )


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
        _unit(self, "theta")
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
class DDPGConfig:
    """Flat DDPG (the paper's "plain DDPG"), built on the shared DDPG block (spec §1)."""

    hidden: tuple[int, ...] = (300, 300)
    """Hidden layer sizes of actor and critic; arm tasks add a third 300 layer [paper]."""
    actor_lr: float = 1e-4
    """Adam learning rate of the actor [decision: DDPG paper]."""
    critic_lr: float = 1e-3
    """Adam learning rate of the critic [decision: DDPG paper]."""
    gamma: float = 0.99
    """Discount [decision]."""
    tau: float = 0.001
    """Polyak rate of the target networks [decision: DDPG paper]."""
    batch_size: int = 64
    """Minibatch size [decision: DDPG paper]."""
    buffer_size: int = 100_000
    """Replay capacity [decision]."""
    learning_starts: int = 1000
    """Environment steps of uniformly random actions before learning starts [decision]."""
    noise: NoiseConfig = field(default_factory=NoiseConfig)
    invert_gradients: bool = False
    """Damp the actor's action gradient near the bounds of its box (Hausknecht & Stone 2016)
    [decision; False = the paper's plain DPG]."""
    action_l2: float = 0.0
    """Penalty weight on the squared unit action in the actor's objective (Andrychowicz et
    al. 2017) [decision; 0 = the paper's plain DPG]."""
    lr_decay: float = 1.0
    """Learning rates are multiplied by this every ``lr_decay_every`` episodes (1 = off)."""
    lr_decay_every: int = 50
    end_is_terminal: bool = False
    """Treat the end of every episode as terminal in the value targets: no bootstrap at the time
    limit either (the paper's arm rule, §III-B: "the target action-state value for the final
    step in each episode was assigned with the reward of the final step"). False: time-limit
    ends bootstrap (spec §3 decision). The presets set it on tasks that terminate (obstacles):
    there, bootstrapping an infinite-horizon value at the time limit makes a collision look
    cheaper than going on (docs/algorithms.md)."""

    def __post_init__(self) -> None:
        _hidden(self)
        _positive(self, "actor_lr", "critic_lr", "batch_size", "buffer_size", "lr_decay_every")
        _unit(self, "gamma", "tau", "lr_decay")
        if self.learning_starts < 0:
            raise ValueError(f"DDPGConfig.learning_starts={self.learning_starts} must be >= 0")
        _buffer(self)


@dataclass(frozen=True)
class LevelConfig:
    """One level (high or low) of HI-DDPG: a DDPG block plus its dynamics model."""

    hidden: tuple[int, ...] = (300, 300)
    """Hidden sizes of actor, critic and model [paper]."""
    lr: float = 2e-4
    """Adam learning rate shared by the level's actor, critic and model [paper]."""
    gamma: float = 0.95
    """Discount: 0.99 high level, 0.95 low level [paper]."""
    tau: float = 0.001
    """Polyak rate of the target networks [decision]."""
    batch_size: int = 64
    """Minibatch size [decision]."""
    buffer_size: int = 10_000
    """Replay capacity: puck D_H = 1e5, D_L = 1e4; arm 1e6 / 1e5 [paper]."""
    noise: NoiseConfig = field(default_factory=NoiseConfig)
    """OU noise on the level's normalised outputs [paper]."""
    invert_gradients: bool = False
    """Damp the actor's action gradient near the bounds of its box so that ``tanh`` does not
    saturate (Hausknecht & Stone 2016) [decision; False = the paper's plain DPG]."""
    action_l2: float = 0.0
    """Penalty weight on the squared unit action in the actor's objective (Andrychowicz et
    al. 2017) [decision; 0 = the paper's plain DPG]."""
    huber_delta: float = 0.0
    """``δ > 0``: the level's critic minimises the Huber loss of its TD error (squared within
    ``δ``, linear beyond), so that rare large errors — the arm's collisions, reward −100 —
    pull its values less than the many small ones near the target [decision; 0 = the
    squared error, DDPG's]."""
    terminal_head: bool = False
    """The critic learns the rewards of the steps that end the episode (the arm's collision,
    −100) in a head of its own and the rest in another, ``Q = Q_run + Q_term``; ``huber_delta``
    then applies to ``Q_run`` only, so a robust fit of the small segment returns no longer
    blurs the collisions' cost (:attr:`DDPGBlock.terminal_head`). HI-DDPG's high level only
    [decision; False = one value, the paper's]."""
    end_is_terminal: bool = False
    """No bootstrap at the end of any episode for this level's critic (as
    :attr:`DDPGConfig.end_is_terminal`; the presets set it on the high level of the
    terminating tasks)."""
    env_terminal: bool = True
    """An environment termination (a collision) ends the level's value: no bootstrap (spec §3).
    False: bootstrap through it. The presets set False for the low level on terminating tasks:
    its reward is intrinsic only, so a collision would end its costs without costing anything,
    and it learned to drive into the obstacle whatever the goal (docs/algorithms.md)."""

    def __post_init__(self) -> None:
        _hidden(self)
        _positive(self, "lr", "batch_size", "buffer_size")
        _unit(self, "gamma", "tau")
        _buffer(self)
        if not (self.huber_delta >= 0 and math.isfinite(self.huber_delta)):
            raise ValueError(f"LevelConfig.huber_delta={self.huber_delta} must be a finite "
                             "number >= 0 (0: the squared TD error)")


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
        _positive(self, "duration_min", "duration_max", "lr_decay_every")
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
        if not (self.intrinsic_action_cost >= 0 and math.isfinite(self.intrinsic_action_cost)):
            raise ValueError(f"HIDDPGConfig.intrinsic_action_cost={self.intrinsic_action_cost} "
                             "must be a finite number >= 0")
        if not (self.intrinsic_rest_weight >= 0 and math.isfinite(self.intrinsic_rest_weight)):
            raise ValueError(f"HIDDPGConfig.intrinsic_rest_weight={self.intrinsic_rest_weight} "
                             "must be a finite number >= 0")
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
        _unit(self, "lr_decay")


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
    meta_hidden: tuple[int, ...] = (300, 300)
    """Hidden sizes of the meta-critic MLP [decision: those of the skills]."""
    meta_lr: float = 1e-3
    """Adam learning rate of the meta-critic [decision]."""
    meta_gamma: float = 0.99
    """Discount of the meta-critic's DQN target [paper]."""
    meta_tau: float = 0.01
    """Polyak rate of the meta-critic's target network, applied every update [decision]."""
    meta_batch_size: int = 64
    """Minibatch size of the meta-critic [decision]."""
    meta_buffer_size: int = 100_000
    """Capacity of the meta-critic's replay of ``(s, k, r, s', terminated)`` [decision]."""
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
        _hidden(self, "meta_hidden")
        _positive(self, "meta_lr", "meta_batch_size", "meta_buffer_size",
                  "epsilon_decay_episodes", "puck_max_speed")
        _unit(self, "meta_gamma", "meta_tau", "epsilon_start", "epsilon_end")
        _unit(self, "epsilon_fraction", closed=False)
        if self.epsilon_end > self.epsilon_start:
            raise ValueError(
                f"HDDPGConfig.epsilon_end={self.epsilon_end} is larger than epsilon_start="
                f"{self.epsilon_start}; it must be <= epsilon_start"
            )
        if not isinstance(self.epsilon_decay_episodes, int):
            raise ValueError(f"HDDPGConfig.epsilon_decay_episodes="
                             f"{self.epsilon_decay_episodes!r} must be an int >= 1")
        if self.meta_batch_size > self.meta_buffer_size:
            raise ValueError(
                f"HDDPGConfig.meta_batch_size={self.meta_batch_size} is larger than "
                f"meta_buffer_size={self.meta_buffer_size}; it must be <= meta_buffer_size"
            )


AgentConfig = DDPGConfig | HIDDPGConfig | HDDPGConfig


@dataclass(frozen=True)
class TrainConfig:
    """A training run: which algorithm on which task, for how long, with what agent config.

    The seeds are not part of the config: one config is trained on many seeds at once.
    """

    algo: str
    """One of :data:`ALGORITHMS`."""
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
        if self.algo not in ALGORITHMS:
            raise ValueError(f"algo={self.algo!r} is unknown; choose one of {list(ALGORITHMS)}")
        _positive(self, "episodes", "eval_every", "chunk_episodes")
        for name in ("episodes", "eval_every", "chunk_episodes"):
            if not isinstance(getattr(self, name), int):
                raise ValueError(f"TrainConfig.{name}={getattr(self, name)!r} must be an int")

    @property
    def env_overrides(self) -> dict[str, Any]:
        return dict(self.env)


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
                                   HDDPGConfig, TrainConfig)}


def register_config_type(cls: type) -> type:
    """Make a config dataclass known to :func:`from_dict` (agents added later use this)."""
    _TYPES[cls.__name__] = cls
    return cls


def from_dict(data: Any) -> Any:
    """Inverse of :func:`to_dict`."""
    if isinstance(data, dict) and "_type" in data:
        cls = _TYPES[data["_type"]]
        kwargs = {k: from_dict(v) for k, v in data.items() if k != "_type"}
        for f in dataclasses.fields(cls):
            if f.name in kwargs and isinstance(kwargs[f.name], list):
                kwargs[f.name] = _tuplify(kwargs[f.name])
        return cls(**kwargs)
    return data


def _tuplify(v: Any) -> Any:
    return tuple(_tuplify(x) for x in v) if isinstance(v, list) else v

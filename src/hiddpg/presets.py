"""Named presets and ``--set key=value`` overrides.

* ``paper``: the paper's hyper-parameters for the task's family (puck or arm), the spec's
  defaults where the paper is silent;
* ``quick``: small networks and budgets, for the README's main job, CI and smoke studies.

:func:`make_config` builds a validated :class:`TrainConfig` from ``(algo, task, preset, sets)``
before anything is compiled, so a bad value fails at once with a message naming it.
"""

from __future__ import annotations

import dataclasses
from typing import Any

from hiddpg.configs import (
    ALGORITHMS,
    HI_DDPG_ALGORITHMS,
    ActorChoice,
    DDPGConfig,
    HDDPGConfig,
    HIDDPGConfig,
    HoldChoice,
    LevelConfig,
    NoiseConfig,
    TrainConfig,
)
from hiddpg.envs import task_name
from hiddpg.overrides import apply_overrides

PRESETS = ("paper", "quick")

#: Stabilisers of both presets' actors: without them ``tanh`` saturates within a few hundred
#: episodes [decision; docs/algorithms.md, "Decisions that make learning work"].
STABILIZE = {"tau": 0.01, "action_l2": 1.0}


def task_family(task: str) -> str:
    """``"puck"`` or ``"arm"``."""
    return "arm" if task_name(task).startswith("Arm") else "puck"


#: Tasks that terminate (collisions): critics on the environment reward do not bootstrap at the
#: time limit, and HI-DDPG's low level (intrinsic reward only) bootstraps through collisions
#: [decision; docs/algorithms.md].
TERMINATING_TASKS = ("PuckObstacle", "ArmObstacle")

#: No action penalty on the arm: its unit action maps to activations in [0, 1], so ``|a|^2``
#: pulls every muscle to 0.5 (co-contraction) instead of to rest [decision].
ARM_ACTION_L2 = 0.0

#: Tasks whose high-level noise falls linearly to 0 over the run: goals drawn near the obstacle
#: collide and blur the high critic's values of the target [decision; docs/algorithms.md].
DECAYING_HIGH_NOISE_TASKS = ("ArmObstacle",)

#: The trajectory tasks' high-level choice: the critic may hold the goal to the end, which the
#: policy gradient cannot find (the return jumps by the switch cost there) [decision].
HOLD_CHOICE = HoldChoice(explore=0.1)

#: HI-DDPG on the trajectory tasks at ``hiddpg reproduce --scale paper``: the critic chooses
#: the duration, the low level learns from hindsight goals and to arrive at rest, no model
#: gradient (the high model would not see the duration) [decision; docs/results.md].
CRITIC_DURATIONS = (
    "agent.choice=critic-durations", "agent.choice.explore=0.5",
    "agent.model_weight=0", "agent.use_model=false",
    "agent.high.action_l2=0.1", "agent.low.noise.final_sigma=0",
    "agent.low_hindsight.fraction=0.8", "agent.rest_term.weight=0.3",
)

#: HI-DDPG on ArmObstacle at ``hiddpg reproduce --scale paper``: hindsight actions for the
#: high level and a Huber loss for its critic, δ 10 then 3 from episode 2160 [decision;
#: docs/results.md].
ARM_HIGH_CRITIC = ("agent.high_hindsight.probability=1", "agent.high.huber.delta=10",
                   "agent.high.huber.late_delta=3", "agent.high.huber.late_episode=2160")


def _paper_agent(algo: str, task: str) -> Any:
    family, name = task_family(task), task_name(task)
    arm = family == "arm"
    end_terminal = name in TERMINATING_TASKS
    action_l2 = ARM_ACTION_L2 if arm else STABILIZE["action_l2"]
    hidden = (300, 300, 300) if arm else (300, 300)
    noise = NoiseConfig(sigma=0.15 if arm else 0.1)
    if algo == "ddpg":
        return DDPGConfig(hidden=hidden, noise=noise, buffer_size=100_000,
                          lr_decay=0.99 if arm else 1.0, action_l2=action_l2,
                          tau=STABILIZE["tau"], end_is_terminal=end_terminal)
    if algo in HI_DDPG_ALGORITHMS:
        switching = name.startswith("PuckTrajectory")
        high_noise = (dataclasses.replace(noise, final_sigma=0.0)
                      if name in DECAYING_HIGH_NOISE_TASKS else noise)
        high = LevelConfig(hidden=hidden, lr=5e-5 if arm else 2e-5, gamma=0.99,
                           buffer_size=1_000_000 if arm else 100_000, noise=high_noise,
                           tau=STABILIZE["tau"], invert_gradients=True,
                           end_is_terminal=end_terminal)
        low = LevelConfig(hidden=hidden, lr=5e-4 if arm else 2e-4, gamma=0.95,
                          buffer_size=100_000 if arm else 10_000, noise=noise,
                          tau=STABILIZE["tau"], action_l2=action_l2,
                          env_terminal=not end_terminal)
        return HIDDPGConfig(
            high=high, low=low,
            duration_min=2.0 if arm else 1.0, duration_max=40.0 if arm else 30.0,
            switch_cost=10.0 if switching else 0.0,
            pretrain_episodes=1000 if arm else 0,
            lr_decay=0.99 if arm else 1.0, high_update_on="step",
            pretrain_fills_high_buffer=True, choice=HOLD_CHOICE if switching else ActorChoice(),
        )
    if algo == "h-ddpg":
        skill = DDPGConfig(hidden=hidden, noise=noise, buffer_size=100_000, gamma=0.99,
                           lr_decay=0.99 if arm else 1.0, action_l2=action_l2,
                           tau=STABILIZE["tau"], end_is_terminal=end_terminal)
        return HDDPGConfig(skill=skill, meta_hidden=hidden)
    raise ValueError(f"no paper preset for algorithm {algo!r} yet")


def _quick_agent(algo: str, task: str) -> Any:
    agent = _paper_agent(algo, task)
    hidden = (64, 64)
    if isinstance(agent, DDPGConfig):
        return dataclasses.replace(agent, hidden=hidden, actor_lr=1e-3, critic_lr=1e-3,
                                   buffer_size=20_000, learning_starts=300)
    if isinstance(agent, HIDDPGConfig):
        return dataclasses.replace(
            agent,
            high=dataclasses.replace(agent.high, hidden=hidden, lr=1e-3, buffer_size=5_000,
                                     batch_size=32),
            low=dataclasses.replace(agent.low, hidden=hidden, lr=1e-3, buffer_size=10_000),
            learning_starts=300, high_learning_starts=32,
            pretrain_episodes=300 if task_family(task) == "puck" else 200,
        )
    if isinstance(agent, HDDPGConfig):
        skill = dataclasses.replace(agent.skill, hidden=hidden, actor_lr=1e-3, critic_lr=1e-3,
                                    buffer_size=20_000, learning_starts=300)
        return dataclasses.replace(agent, skill=skill, meta_hidden=hidden, meta_lr=1e-3,
                                   meta_buffer_size=20_000)
    return agent


#: training budget per (preset, family): episodes, eval_every, chunk_episodes
_BUDGETS = {
    ("paper", "puck"): (3000, 20, 200),
    ("paper", "arm"): (3000, 20, 100),
    ("quick", "puck"): (1500, 10, 100),
    ("quick", "arm"): (1500, 10, 100),
}


def make_config(
    algo: str, task: str, preset: str = "paper", sets: list[str] | tuple[str, ...] = ()
) -> TrainConfig:
    """The validated config for ``algo`` on ``task`` under ``preset`` with ``sets`` applied."""
    if algo not in ALGORITHMS:
        raise ValueError(f"unknown algorithm {algo!r}; choose one of {list(ALGORITHMS)}")
    if preset not in PRESETS:
        raise ValueError(f"unknown preset {preset!r}; choose one of {list(PRESETS)}")
    task = task_name(task)
    agent = _paper_agent(algo, task) if preset == "paper" else _quick_agent(algo, task)
    episodes, eval_every, chunk = _BUDGETS[(preset, task_family(task))]
    cfg = TrainConfig(algo=algo, task=task, agent=agent, episodes=episodes,
                      eval_every=eval_every, chunk_episodes=chunk, preset=preset)
    cfg = apply_overrides(cfg, sets)
    if isinstance(cfg.agent, HDDPGConfig) and not any(
            s.strip().startswith("agent.epsilon_decay_episodes") for s in sets):
        # ε decays over the first epsilon_fraction of *this* run's episodes (spec §4)
        decay = max(1, round(cfg.agent.epsilon_fraction * cfg.episodes))
        cfg = dataclasses.replace(
            cfg, agent=dataclasses.replace(cfg.agent, epsilon_decay_episodes=decay))
    if isinstance(cfg.agent, HIDDPGConfig):
        cfg = _noise_decay_over_run(cfg, sets)
    return cfg


def _noise_decay_over_run(cfg: TrainConfig, sets: list[str] | tuple[str, ...]) -> TrainConfig:
    """A level whose noise decays (``final_sigma >= 0``) reaches its end with the run, unless
    ``agent.<level>.noise.decay_episodes`` is set."""
    levels = {}
    for name in ("high", "low"):
        level = getattr(cfg.agent, name)
        given = any(s.strip().startswith(f"agent.{name}.noise.decay_episodes") for s in sets)
        if level.noise.decays and not given:
            noise = dataclasses.replace(level.noise, decay_episodes=max(1, cfg.episodes))
            levels[name] = dataclasses.replace(level, noise=noise)
    return dataclasses.replace(cfg, agent=dataclasses.replace(cfg.agent, **levels))

"""Named presets and ``--set key=value`` overrides.

* ``paper``: the paper's algorithm and hyper-parameters for the task's family (puck or arm; a
  user's ``custom`` task gets the puck values), the spec's decisions where the paper is silent,
  and nothing else: no stabiliser, no extension (docs/hyperparameters.md, "The paper preset");
* ``paper+``: ``paper`` plus the generic changes of :data:`hiddpg.variants.PAPER_PLUS`, built
  in :mod:`hiddpg.variants`, on the paper's budget;
* ``quick``: small networks and budgets on top of the stabilised configuration
  (:func:`ddpg_stable`, ...: the paper's values plus the stabilisers and per-task choices of
  docs/hyperparameters.md, "Decisions that make learning work"), for the README's main job, CI and
  smoke studies.

Each algorithm names its preset builders (``ddpg_paper``, ``hi_ddpg_quick``, ...) in
:mod:`hiddpg.algorithms`. :func:`make_config` builds a validated :class:`TrainConfig` from
``(algo, task, preset, sets)`` before anything is compiled, so a bad value fails at once with a
message naming it.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from hiddpg.algorithms import get_algorithm
from hiddpg.configs import (
    ActorChoice,
    DDPGConfig,
    EagerHighLevel,
    HDDPGConfig,
    HIDDPGConfig,
    HoldChoice,
    LevelConfig,
    MetaCriticConfig,
    NoiseConfig,
    TrainConfig,
)
from hiddpg.envs import TASKS
from hiddpg.envs import task_name as _registered_name
from hiddpg.host.task import is_gym_task
from hiddpg.overrides import apply_overrides

PRESETS = ("paper", "paper+", "quick")
#: presets that train on another preset's budget (episodes, evaluation, chunks).
BUDGET_OF = {"paper+": "paper"}

#: Stabilisers of the stabilised configuration's actors: without them ``tanh`` saturates within
#: a few hundred episodes [decision; docs/hyperparameters.md, "Decisions that make learning work"].
STABILIZE = {"tau": 0.01, "action_l2": 1.0}


def task_name(task: str) -> str:
    """A registered task's name (``hiddpg/Name-v0`` -> ``Name``); a Gymnasium task of the host
    engine (``gym:<id>``, :mod:`hiddpg.host`) as it is: none of the per-task choices below
    names one."""
    return task if is_gym_task(task) else _registered_name(task)


def task_family(task: str) -> str:
    """The family the task declares (:func:`hiddpg.register_task`): puck, arm or custom; a
    Gymnasium task (``gym:<id>``) is ``custom``: the presets' generic values, nothing of the
    puck or arm tasks."""
    return "custom" if is_gym_task(task) else TASKS[task_name(task)].family


#: Tasks that terminate (collisions): critics on the environment reward do not bootstrap at the
#: time limit, and HI-DDPG's low level (intrinsic reward only) bootstraps through collisions
#: [decision; docs/hyperparameters.md].
TERMINATING_TASKS = ("PuckObstacle", "ArmObstacle")

#: No action penalty on the arm: its unit action maps to activations in [0, 1], so ``|a|^2``
#: pulls every muscle to 0.5 (co-contraction) instead of to rest [decision].
ARM_ACTION_L2 = 0.0

#: Tasks whose high-level noise falls linearly to 0 over the run: goals drawn near the obstacle
#: collide and blur the high critic's values of the target [decision; docs/hyperparameters.md].
DECAYING_HIGH_NOISE_TASKS = ("ArmObstacle",)

#: The trajectory tasks: HI-DDPG pays a switch cost and holds goals there [paper, decision].
SWITCHING_TASKS = ("PuckTrajectory1", "PuckTrajectory2", "PuckTrajectory3")

#: The trajectory tasks' high-level choice: the critic may hold the goal to the end, which the
#: policy gradient cannot find (the return jumps by the switch cost there) [decision].
HOLD_CHOICE = HoldChoice(explore=0.1)

#: HI-DDPG on the trajectory tasks at ``hiddpg reproduce --scale paper``: the critic chooses
#: the duration, the low level learns from hindsight goals and to arrive at rest, no model
#: gradient (the high model would not see the duration) [decision; docs/deviations.md §2.3].
CRITIC_DURATIONS = (
    "agent.choice=critic-durations", "agent.choice.explore=0.5",
    "agent.model_weight=0", "agent.use_model=false",
    "agent.high.action_l2=0.1", "agent.low.noise.final_sigma=0",
    "agent.low_hindsight.fraction=0.8", "agent.rest_term.weight=0.3",
)

#: HI-DDPG on ArmObstacle at ``hiddpg reproduce --scale paper``: hindsight actions for the
#: high level and a Huber loss for its critic, δ 10 then 3 from episode 2160 [decision;
#: docs/deviations.md §2.3].
ARM_HIGH_CRITIC = ("agent.high_hindsight.probability=1", "agent.high.huber.delta=10",
                   "agent.high.huber.late_delta=3", "agent.high.huber.late_episode=2160")


@dataclass(frozen=True)
class FamilyValues:
    """The values of a task family that the presets use (the paper's, or [decision])."""

    hidden: tuple[int, ...]
    sigma: float
    lr_decay: float
    action_l2: float
    high_lr: float
    low_lr: float
    high_buffer: int
    low_buffer: int
    duration_min: float
    duration_max: float
    pretrain_episodes: int
    quick_pretrain_episodes: int
    budgets: tuple[tuple[str, tuple[int, int, int]], ...]
    """Per preset: episodes, eval_every, chunk_episodes."""


PUCK = FamilyValues(hidden=(300, 300), sigma=0.1, lr_decay=1.0,
                    action_l2=STABILIZE["action_l2"], high_lr=2e-5, low_lr=2e-4,
                    high_buffer=100_000, low_buffer=10_000, duration_min=1.0, duration_max=30.0,
                    pretrain_episodes=0, quick_pretrain_episodes=300,
                    budgets=(("paper", (3000, 20, 200)), ("quick", (1500, 10, 100))))
ARM = FamilyValues(hidden=(300, 300, 300), sigma=0.15, lr_decay=0.99, action_l2=ARM_ACTION_L2,
                   high_lr=5e-5, low_lr=5e-4, high_buffer=1_000_000, low_buffer=100_000,
                   duration_min=2.0, duration_max=40.0, pretrain_episodes=1000,
                   quick_pretrain_episodes=200,
                   budgets=(("paper", (3000, 20, 100)), ("quick", (1500, 10, 100))))
#: Values per family; a user's ``custom`` task gets the puck's, a generic default [decision].
FAMILY_VALUES = {"puck": PUCK, "arm": ARM, "custom": PUCK}


def family_values(task: str) -> FamilyValues:
    """The preset values of ``task``'s family."""
    return FAMILY_VALUES[task_family(task)]


def ddpg_paper(task: str) -> DDPGConfig:
    """Flat DDPG as the paper runs it: the family's networks, OU noise and learning-rate decay
    (arm), the DDPG paper's rates, τ and batch; no action penalty, the time limit bootstraps."""
    v = family_values(task)
    return DDPGConfig(hidden=v.hidden, noise=NoiseConfig(sigma=v.sigma), buffer_size=100_000,
                      lr_decay=v.lr_decay)


def _level(v: FamilyValues, lr: float, gamma: float, buffer_size: int) -> LevelConfig:
    return LevelConfig(hidden=v.hidden, lr=lr, gamma=gamma, buffer_size=buffer_size,
                       noise=NoiseConfig(sigma=v.sigma))


def hi_ddpg_paper(task: str) -> HIDDPGConfig:
    """HI-DDPG as Algorithm 1 runs it: the actor chooses goal and duration, one high-level
    update per segment end, the model-based gradient at both levels, constant OU noise,
    low-level pre-training on the arm; the trajectory tasks pay the paper's switch cost."""
    v = family_values(task)
    return HIDDPGConfig(
        high=_level(v, v.high_lr, 0.99, v.high_buffer), low=_level(v, v.low_lr, 0.95, v.low_buffer),
        duration_min=v.duration_min, duration_max=v.duration_max,
        switch_cost=10.0 if task_name(task) in SWITCHING_TASKS else 0.0,
        pretrain_episodes=v.pretrain_episodes, lr_decay=v.lr_decay)


def h_ddpg_paper(task: str) -> HDDPGConfig:
    """h-DDPG whose skills are the paper preset's DDPG (γ 0.99) and whose meta-critic has the
    same networks."""
    skill = dataclasses.replace(ddpg_paper(task), gamma=0.99)
    return HDDPGConfig(skill=skill, meta=MetaCriticConfig(hidden=skill.hidden))


def ddpg_stable(task: str) -> DDPGConfig:
    """:func:`ddpg_paper` with the stabilisers (τ, the action penalty) and, on the tasks that
    terminate, no bootstrap at the time limit [decision]."""
    v = family_values(task)
    return dataclasses.replace(ddpg_paper(task), action_l2=v.action_l2, tau=STABILIZE["tau"],
                               end_is_terminal=task_name(task) in TERMINATING_TASKS)


def hi_ddpg_stable(task: str) -> HIDDPGConfig:
    """:func:`hi_ddpg_paper` with the stabilisers and per-task choices [decision]: τ,
    inverted gradients and the action penalty; the eager high level; on the tasks that
    terminate, no high-level bootstrap at the time limit and a low level that bootstraps
    through collisions; the hold choice on the trajectory tasks; on ArmObstacle a high-level
    noise decaying to 0; the model term unmasked at terminal transitions, as its measurements
    were made."""
    v, name = family_values(task), task_name(task)
    agent = hi_ddpg_paper(task)
    end_terminal = name in TERMINATING_TASKS
    high_noise = (dataclasses.replace(agent.high.noise, final_sigma=0.0)
                  if name in DECAYING_HIGH_NOISE_TASKS else agent.high.noise)
    high = dataclasses.replace(agent.high, noise=high_noise, tau=STABILIZE["tau"],
                               invert_gradients=True, end_is_terminal=end_terminal)
    low = dataclasses.replace(agent.low, tau=STABILIZE["tau"], action_l2=v.action_l2,
                              env_terminal=not end_terminal)
    return dataclasses.replace(
        agent, high=high, low=low, eager_high=EagerHighLevel(), model_masked=False,
        choice=HOLD_CHOICE if name in SWITCHING_TASKS else ActorChoice())


def h_ddpg_stable(task: str) -> HDDPGConfig:
    """h-DDPG whose skills are :func:`ddpg_stable` (γ 0.99)."""
    skill = dataclasses.replace(ddpg_stable(task), gamma=0.99)
    return HDDPGConfig(skill=skill, meta=MetaCriticConfig(hidden=skill.hidden))


#: The networks of the ``quick`` preset.
QUICK_HIDDEN = (64, 64)


def ddpg_quick(task: str) -> DDPGConfig:
    """:func:`ddpg_stable` with small networks, faster learning rates and a short random
    phase."""
    return dataclasses.replace(ddpg_stable(task), hidden=QUICK_HIDDEN, actor_lr=1e-3,
                               critic_lr=1e-3, buffer_size=20_000, learning_starts=300)


def hi_ddpg_quick(task: str) -> HIDDPGConfig:
    """:func:`hi_ddpg_stable` with small networks and buffers and a short pre-training."""
    agent = hi_ddpg_stable(task)
    return dataclasses.replace(
        agent,
        high=dataclasses.replace(agent.high, hidden=QUICK_HIDDEN, lr=1e-3, buffer_size=5_000,
                                 batch_size=32),
        low=dataclasses.replace(agent.low, hidden=QUICK_HIDDEN, lr=1e-3, buffer_size=10_000),
        learning_starts=300, high_learning_starts=32,
        pretrain_episodes=family_values(task).quick_pretrain_episodes,
    )


def _without_model(agent: HIDDPGConfig) -> HIDDPGConfig:
    """The paper's HI-DDPG-wo-model ablation: no model-based gradient, no models trained."""
    return dataclasses.replace(agent, model_weight=0.0, use_model=False)


def hi_ddpg_wo_model_paper(task: str) -> HIDDPGConfig:
    return _without_model(hi_ddpg_paper(task))


def hi_ddpg_wo_model_quick(task: str) -> HIDDPGConfig:
    return _without_model(hi_ddpg_quick(task))


def h_ddpg_quick(task: str) -> HDDPGConfig:
    """:func:`h_ddpg_stable` with small networks and the quick DDPG settings for the skills."""
    agent = h_ddpg_stable(task)
    skill = dataclasses.replace(agent.skill, hidden=QUICK_HIDDEN, actor_lr=1e-3,
                                critic_lr=1e-3, buffer_size=20_000, learning_starts=300)
    meta = dataclasses.replace(agent.meta, hidden=QUICK_HIDDEN, lr=1e-3, buffer_size=20_000)
    return dataclasses.replace(agent, skill=skill, meta=meta)


def make_config(
    algo: str, task: str, preset: str = "paper", sets: list[str] | tuple[str, ...] = ()
) -> TrainConfig:
    """The validated config for ``algo`` on ``task`` under ``preset`` with ``sets`` applied."""
    algorithm = get_algorithm(algo)
    if preset not in PRESETS:
        raise ValueError(f"unknown preset {preset!r}; choose one of {list(PRESETS)}")
    task = task_name(task)
    agent = algorithm.preset(preset, task)
    episodes, eval_every, chunk = dict(family_values(task).budgets)[BUDGET_OF.get(preset, preset)]
    cfg = TrainConfig(algo=algo, task=task, agent=agent, episodes=episodes,
                      eval_every=eval_every, chunk_episodes=chunk, preset=preset)
    return algorithm.finished(apply_overrides(cfg, sets), sets)


def h_ddpg_finish(cfg: TrainConfig, sets: list[str] | tuple[str, ...]) -> TrainConfig:
    """ε decays over the first ``epsilon_fraction`` of this run's episodes (spec §4), unless
    ``agent.epsilon_decay_episodes`` is set."""
    if any(s.strip().startswith("agent.epsilon_decay_episodes") for s in sets):
        return cfg
    decay = max(1, round(cfg.agent.epsilon_fraction * cfg.episodes))
    return dataclasses.replace(
        cfg, agent=dataclasses.replace(cfg.agent, epsilon_decay_episodes=decay))


def hi_ddpg_finish(cfg: TrainConfig, sets: list[str] | tuple[str, ...]) -> TrainConfig:
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

"""The stabilised configuration's per-task decisions, as the quick preset carries them
(docs/hyperparameters.md, "Decisions that make learning work"); the paper preset has none of them
(tests/test_paper_preset.py)."""

from __future__ import annotations

import pytest

from hiddpg.configs import CriticDurations, EagerHighLevel, GoalHindsight, RestTerm
from hiddpg.envs import make
from hiddpg.presets import CRITIC_DURATIONS, STABILIZE, make_config

PUCK = ("PuckTrajectory1", "PuckTrajectory2", "PuckTrajectory3", "PuckObstacle")
ARM = ("ArmReach", "ArmObstacle")


def action_penalty(algo: str, task: str, preset: str) -> float:
    """The penalty of the block that outputs the environment's actions."""
    agent = make_config(algo, task, preset).agent
    if algo == "hi-ddpg":
        assert agent.high.action_l2 == 0.0  # goals are never penalised
        return agent.low.action_l2
    return agent.skill.action_l2 if algo == "h-ddpg" else agent.action_l2


@pytest.mark.parametrize("preset", ["quick"])
@pytest.mark.parametrize("algo", ["ddpg", "h-ddpg", "hi-ddpg"])
def test_the_action_penalty_is_for_forces_only(algo, preset):
    """Puck: the penalty on the unit action pulls forces to 0. Arm: unit 0 is activation 0.5
    (co-contraction), so the arm presets have no penalty."""
    for task in PUCK:
        assert action_penalty(algo, task, preset) == STABILIZE["action_l2"] == 1.0
    for task in ARM:
        assert action_penalty(algo, task, preset) == 0.0
    env, _ = make("ArmObstacle")
    assert (float(env.action_low), float(env.action_high)) == (0.0, 1.0)


@pytest.mark.parametrize("preset", ["quick"])
@pytest.mark.parametrize("task", PUCK + ARM)
def test_hi_ddpg_presets(task, preset):
    for algo in ("hi-ddpg", "hi-ddpg-wo-model"):
        agent = make_config(algo, task, preset).agent
        assert agent.eager_high == EagerHighLevel(every_step=True, pretraining_segments=True)
        terminating = task in ("PuckObstacle", "ArmObstacle")
        assert agent.high.end_is_terminal == terminating
        assert agent.low.env_terminal == (not terminating)
        assert agent.pretrain_episodes == (200 if task.startswith("Arm") else 300)


@pytest.mark.parametrize("preset", ["quick"])
@pytest.mark.parametrize("task", PUCK + ARM)
def test_high_level_noise_decays_on_the_arm_obstacle_task_only(task, preset):
    for algo in ("hi-ddpg", "hi-ddpg-wo-model"):
        cfg = make_config(algo, task, preset, ["episodes=1234"])
        high, low = cfg.agent.high.noise, cfg.agent.low.noise
        assert not low.decays
        if task == "ArmObstacle":  # sigma -> 0 over exactly this run's episodes
            assert (high.sigma, high.final_sigma, high.decay_episodes) == (0.15, 0.0, 1234)
        else:
            assert not high.decays
    explicit = make_config("hi-ddpg", "ArmObstacle", preset,
                           ["episodes=1234", "agent.high.noise.decay_episodes=100"])
    assert explicit.agent.high.noise.decay_episodes == 100


def test_the_critic_durations_sets_make_a_valid_argmax_config_with_low_noise_to_zero():
    """``CRITIC_DURATIONS`` on top of the hold-choice preset: the critic's durations, no model,
    goals penalised by 0.1, the low level's noise reaching 0 with this run's episodes, its
    hindsight goals and the rest weight."""
    for preset in ("quick",):
        cfg = make_config("hi-ddpg", "PuckTrajectory2", preset,
                          ["episodes=700", *CRITIC_DURATIONS])
        agent = cfg.agent
        assert agent.choice == CriticDurations(explore=0.5)
        assert agent.model_weight == 0.0 and not agent.use_model
        assert agent.high.action_l2 == 0.1 and agent.low.action_l2 == 1.0
        low = agent.low.noise
        assert (low.sigma, low.final_sigma, low.decay_episodes) == (0.1, 0.0, 700)
        assert not agent.high.noise.decays
        assert (agent.low_hindsight, agent.rest_term) == (GoalHindsight(0.8), RestTerm(0.3))
    explicit = make_config("hi-ddpg", "PuckTrajectory2", "quick",
                           ["episodes=700", *CRITIC_DURATIONS, "agent.low.noise.decay_episodes=9"])
    assert explicit.agent.low.noise.decay_episodes == 9

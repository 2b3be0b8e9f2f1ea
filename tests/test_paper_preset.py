"""``--preset paper`` is the paper and nothing else: every value below is the paper's or a
tagged spec decision (docs/hyperparameters.md, "The paper preset"), written out here independently
of src/hiddpg/presets.py, and no stabiliser or extension is on."""

from __future__ import annotations

import pytest

from hiddpg.configs import ActorChoice, LevelConfig, NoiseConfig, to_dict
from hiddpg.presets import make_config

PUCK = ("PuckTrajectory1", "PuckTrajectory2", "PuckTrajectory3", "PuckObstacle")
ARM = ("ArmReach", "ArmObstacle")

#: family -> the paper's values (§III-A puck, §III-B arm) and the spec's decisions
PAPER = {
    "puck": dict(hidden=(300, 300), sigma=0.1, high_lr=2e-5, low_lr=2e-4, high_buffer=100_000,
                 low_buffer=10_000, lr_decay=1.0, pretrain=0, duration=(1.0, 30.0)),
    "arm": dict(hidden=(300, 300, 300), sigma=0.15, high_lr=5e-5, low_lr=5e-4,
                high_buffer=1_000_000, low_buffer=100_000, lr_decay=0.99, pretrain=1000,
                duration=(2.0, 40.0)),
}


def family(task: str) -> dict:
    return PAPER["arm" if task.startswith("Arm") else "puck"]


def paper_level(task: str, lr: float, gamma: float, buffer_size: int) -> LevelConfig:
    """A level exactly as the paper and the spec give it: τ 0.001, batch 64, constant OU noise
    (α 0.05), no action penalty, no inverted gradients, bootstrap at the time limit, only the
    environment terminates, no Huber loss."""
    v = family(task)
    return LevelConfig(hidden=v["hidden"], gamma=gamma, tau=0.001, batch_size=64,
                       buffer_size=buffer_size, action_l2=0.0,
                       noise=NoiseConfig(kind="ou", theta=0.05, sigma=v["sigma"]),
                       invert_gradients=False, end_is_terminal=False, lr=lr, huber=None,
                       env_terminal=True)


@pytest.mark.parametrize("task", PUCK + ARM)
@pytest.mark.parametrize("algo", ["hi-ddpg", "hi-ddpg-wo-model"])
def test_hi_ddpg_paper_preset_is_the_paper(algo, task):
    v = family(task)
    agent = make_config(algo, task, "paper").agent
    assert agent.high == paper_level(task, v["high_lr"], 0.99, v["high_buffer"])
    assert agent.low == paper_level(task, v["low_lr"], 0.95, v["low_buffer"])
    assert (agent.duration_min, agent.duration_max) == v["duration"]
    assert agent.switch_cost == (10.0 if task.startswith("PuckTrajectory") else 0.0)
    assert agent.pretrain_episodes == v["pretrain"]
    assert (agent.lr_decay, agent.lr_decay_every) == (v["lr_decay"], 50)
    assert agent.learning_starts == 1000
    # Algorithm 1: the actor chooses, one high-level update per segment, nothing added
    assert agent.choice == ActorChoice()
    assert agent.eager_high is None
    assert (agent.low_hindsight, agent.high_hindsight, agent.rest_term) == (None, None, None)
    if algo == "hi-ddpg":
        assert (agent.model_weight, agent.use_model, agent.model_masked) == (1.0, True, True)
    else:
        assert (agent.model_weight, agent.use_model) == (0.0, False)


@pytest.mark.parametrize("task", PUCK + ARM)
def test_ddpg_and_h_ddpg_paper_presets(task):
    v = family(task)
    ddpg = make_config("ddpg", task, "paper").agent
    expected = dict(hidden=list(v["hidden"]), gamma=0.99, tau=0.001, batch_size=64,
                    buffer_size=100_000, action_l2=0.0, invert_gradients=False,
                    end_is_terminal=False, actor_lr=1e-4, critic_lr=1e-3, learning_starts=1000,
                    lr_decay=v["lr_decay"], lr_decay_every=50)
    got = to_dict(ddpg)
    assert {k: got[k] for k in expected} == expected
    assert ddpg.noise == NoiseConfig(kind="ou", theta=0.05, sigma=v["sigma"])
    h = make_config("h-ddpg", task, "paper").agent
    assert h.skill == ddpg  # gamma is 0.99 either way
    assert h.meta.hidden == v["hidden"]
    assert (h.epsilon_start, h.epsilon_end, h.epsilon_fraction) == (1.0, 0.1, 0.2)


def test_the_quick_preset_keeps_its_stabilisers():
    """The quick preset shrinks the stabilised configuration, not the paper's (docs/deviations.md
    §2.2): ``hiddpg reproduce --scale quick`` trains these stabilisers."""
    agent = make_config("hi-ddpg", "PuckObstacle", "quick").agent
    assert agent.high.tau == agent.low.tau == 0.01 and agent.high.invert_gradients
    assert agent.low.action_l2 == 1.0 and agent.eager_high is not None
    assert not agent.model_masked
    assert make_config("ddpg", "PuckObstacle", "quick").agent.end_is_terminal

"""Every agent, with every part of HI-DDPG switched on, trains and evaluates under JAX's
key-reuse checker (typed keys): no key feeds two draws."""

from __future__ import annotations

import jax
import numpy as np
import pytest

from hiddpg.presets import make_config
from hiddpg.train import Trainer

FAST = ["agent.hidden=[16,16]"]
HI = ["agent.learning_starts=0", "agent.high_learning_starts=1", "agent.pretrain_episodes=0",
      "agent.high.hidden=[16,16]", "agent.low.hidden=[16,16]"]
CASES = {
    "ddpg": ("ddpg", "PuckTrajectory1", [*FAST, "agent.learning_starts=0"]),
    "h-ddpg": ("h-ddpg", "PuckObstacle", ["agent.skill.learning_starts=0",
                                          "agent.skill.hidden=[16,16]", "agent.meta.hidden=[16]"]),
    "hi-ddpg hold": ("hi-ddpg", "PuckTrajectory1", [*HI, "agent.choice.explore=0.5"]),
    "hi-ddpg critic durations, hindsight": (
        "hi-ddpg", "PuckTrajectory2",
        [*HI, "agent.choice=critic-durations", "agent.low_hindsight.fraction=0.8",
         "agent.high_hindsight.probability=0.5", "agent.rest_term.weight=0.3",
         "agent.high.huber.delta=10", "agent.high.huber.late_delta=3",
         "agent.high.huber.late_episode=1"]),
    "hi-ddpg arm": ("hi-ddpg", "ArmObstacle", [*HI, "agent.high_hindsight.probability=1"]),
}


@pytest.fixture
def key_reuse_checked():
    jax.config.update("jax_debug_key_reuse", True)
    yield
    jax.config.update("jax_debug_key_reuse", False)


@pytest.mark.parametrize("name", CASES)
def test_no_key_is_used_twice(name, key_reuse_checked):
    algo, task, sets = CASES[name]
    trainer = Trainer(make_config(algo, task, "quick", sets))
    agent, params = trainer.agent, trainer.env_params
    state = agent.init(jax.random.key(0), params)
    train = jax.jit(agent.train_episode)
    for k in (1, 2):
        state, metrics = train(jax.random.key(k), state, params)
    assert np.isfinite(float(metrics["return"]))
    metrics, _ = jax.jit(agent.evaluate)(jax.random.key(3), state, params)
    assert np.isfinite(float(metrics["return"]))


def test_the_checker_is_on_in_these_tests(key_reuse_checked):
    def twice(key):
        return jax.random.uniform(key) + jax.random.uniform(key)

    with pytest.raises(Exception, match="(?i)reuse"):
        jax.jit(twice)(jax.random.key(0))

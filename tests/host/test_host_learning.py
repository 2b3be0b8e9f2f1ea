"""Learning test of the host loop: h-DDPG (quick preset) on PuckTrajectory1 through its
Gymnasium adapter beats the uniformly random skills of its first episodes by a clear margin in
60 episodes, as the JAX engine's test (tests/agents/test_h_ddpg.py) asks of it.

The first 10 episodes (``learning_starts`` = 300 steps) choose skills and speeds uniformly at
random and return -76 on average; seeds 0 and 1 trained for 60 episodes return -23 and -28
(noise-free evaluation)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from hiddpg.host import HostTrainer
from hiddpg.presets import make_config
from hiddpg.train import seed_keys

pytestmark = pytest.mark.slow

EPISODES, SEEDS = 60, [0, 1]


def test_h_ddpg_beats_its_random_skills():
    config = make_config("h-ddpg", "PuckTrajectory1", "quick",
                         [f"episodes={EPISODES}", "eval_every=30", "chunk_episodes=60"])
    trainer = HostTrainer(dataclasses.replace(config, task="gym:hiddpg/PuckTrajectory1-v0"))
    state = trainer.init_seeds(seed_keys(SEEDS))
    state, train, _ = trainer.run_chunk_seeds(state, EPISODES)
    n_random = config.agent.skill.learning_starts // 30
    random_returns = train["return"][:, :n_random]
    final, traj = trainer.evaluate_seeds(state, seed_keys(SEEDS))
    assert random_returns.mean() < -30.0
    assert np.all(final["return"] > random_returns.mean() + 15.0), (final, random_returns)
    assert traj["skill"].shape == (2, 30) and traj["obs"].shape == (2, 30, 4)
    np.testing.assert_array_equal(train["env_steps"][:, -1], [30 * EPISODES] * 2)

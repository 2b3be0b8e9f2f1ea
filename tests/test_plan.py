"""What a run will do, said before it starts (hiddpg.plan): the episodes, the step bound from
the task's horizon, the checkpoint's size from the state's shapes, and durations in words."""

from __future__ import annotations

import jax
import numpy as np
import pytest
from flax import serialization

from hiddpg.envs import make
from hiddpg.plan import describe, eta_text, plural, size_text, state_bytes
from hiddpg.presets import make_config
from hiddpg.runs import make_trainer
from hiddpg.train import seed_keys

TINY = ["episodes=30", "eval_every=5", "chunk_episodes=10", "agent.hidden=[16,16]"]


def test_describe_a_new_run():
    config = make_config("hi-ddpg", "PuckTrajectory1", "quick", [])
    _, params = make("PuckTrajectory1")
    steps = 5 * 1500 * params.max_steps
    assert steps == 225_000
    size = size_text(state_bytes(make_trainer(config), 5))
    assert describe(config, range(5)) == (
        "hi-ddpg on PuckTrajectory1 (preset quick): 5 seeds × 1,500 episodes = 7,500 episodes, "
        f"at most {steps:,} environment steps in training; evaluation every 10 episodes; "
        f"checkpoint about {size} after every 100 episodes")


def test_describe_a_resumed_run_with_env_overrides_and_one_seed():
    config = make_config("ddpg", "ArmReach", "quick", TINY + ["env.max_steps=12"])
    text = describe(config, [7], done=10)
    assert text.startswith("ddpg on ArmReach (preset quick, env max_steps=12): 1 seed × 30 "
                           "episodes from episode 10 = 20 episodes to go, at most 240 "
                           "environment steps in training; evaluation every 5 episodes; "
                           "checkpoint about ")
    assert text.endswith(" after every 10 episodes")
    # 2 seeds, 20 episodes left, 50 steps each at the default horizon
    default = make_config("ddpg", "ArmReach", "quick", TINY)
    assert "at most 2,000 environment steps" in describe(default, [0, 1], done=10)


def test_state_bytes_match_the_real_state_and_its_checkpoint():
    config = make_config("ddpg", "PuckTrajectory1", "quick", TINY)
    trainer = make_trainer(config)
    state = trainer.init_seeds(seed_keys([0, 1, 2]))
    real = sum(np.asarray(x).nbytes for x in jax.tree.leaves(state))
    assert state_bytes(trainer, 3) == real
    checkpoint = len(serialization.to_bytes(jax.device_get(state)))
    assert real <= checkpoint < 1.01 * real + 4096
    # more seeds, proportionally more bytes
    assert state_bytes(trainer, 6) == 2 * real


@pytest.mark.parametrize(("seconds", "text"), [
    (0, "under a minute"), (59.9, "under a minute"), (89, "about 1 min"),
    (91, "about 2 min"), (180, "about 3 min"), (3599, "about 1 h"),
    (7200, "about 2 h"), (7800, "about 2 h 10 min"), (float("inf"), "unknown"),
])
def test_eta_text(seconds, text):
    assert eta_text(seconds) == text


@pytest.mark.parametrize(("nbytes", "text"), [
    (512, "512 B"), (310_000, "310 kB"), (6_618_560, "6.6 MB"), (72_742_120, "73 MB"),
    (1_234_000_000, "1.2 GB"),
])
def test_size_text(nbytes, text):
    assert size_text(nbytes) == text


def test_plural():
    assert [plural(1, "seed"), plural(5, "seed"), plural(1500, "episode")] == [
        "1 seed", "5 seeds", "1,500 episodes"]

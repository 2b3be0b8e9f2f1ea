"""The host loop's training steps update the replay buffer in place (:mod:`hiddpg.host.loop`):
for a seed that is a group of its own (CPU), the compiled per-step learn call (``observe``) and
the per-episode calls that return the agent's state (``begin``, ``finish``) give the donated
buffer back in its own memory and hold no copy of it. A copy there is a pass over the whole
buffer at every step, which dominates a step's time with a large buffer."""

from __future__ import annotations

import dataclasses

import jax
import numpy as np

from hiddpg.host import HostTrainer
from hiddpg.host.loop import split
from hiddpg.presets import make_config
from hiddpg.train import seed_keys

#: tiny networks and batch, a buffer far larger than everything else a step holds
CONFIG = dataclasses.replace(
    make_config("ddpg", "PuckTrajectory1", "quick",
                ["agent.hidden=[8,8]", "agent.learning_starts=0", "agent.buffer_size=50000",
                 "agent.batch_size=8"]),
    task="gym:hiddpg/PuckTrajectory1-v0")


def test_training_steps_update_the_replay_buffer_in_place():
    trainer = HostTrainer(CONFIG)
    group = slice(0, 1)
    (part,) = split(trainer.init_seeds(seed_keys([0])), [group])
    buffer = sum(x.nbytes for x in jax.tree.leaves(part.agent.buffer.data))
    steps = trainer.engine.train.steps(group)
    key, obs = jax.random.PRNGKey(1), np.zeros(trainer.env.obs_dim, np.float32)
    compiled = {"begin": steps.begin.lower(part.agent, key, obs).compile()}
    agent, carry = steps.begin(part.agent, key, obs)
    inner, _, info = steps.act(agent, carry)
    compiled["observe"] = steps.observe.lower(agent, carry, inner, info, obs, np.float32(0),
                                              np.bool_(False), np.bool_(False)).compile()
    compiled["finish"] = steps.finish.lower(agent, carry).compile()
    for name, call in compiled.items():
        memory = call.memory_analysis()
        assert memory.alias_size_in_bytes >= buffer, name  # returned in the donated memory
        assert memory.temp_size_in_bytes < buffer / 4, name  # with no copy in between

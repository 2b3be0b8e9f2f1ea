"""The host loop learns what the JAX engine learns: with one seed, the same config on our task
through its Gymnasium adapter (``gym:hiddpg/PuckTrajectory1-v0``) gives the JAX engine's first
updates, episode metrics, evaluation and trajectory to float tolerance (on CPU they agree bit
for bit: the same compiled steps, the same random streams).

Tiny networks; learning starts at environment step 10 of the 30-step episodes, so the first
episode holds 20 updates of every level (HI-DDPG: no pre-training, high-level updates from
2 stored segments)."""

from __future__ import annotations

import dataclasses

import jax
import numpy as np
import pytest

from hiddpg.presets import make_config
from hiddpg.train import Trainer, make_trainer, seed_keys

TASK = "gym:hiddpg/PuckTrajectory1-v0"
EPISODES = ["episodes=2", "eval_every=2", "chunk_episodes=2"]
#: tiny networks, learning from step 10 of episode 1 (test_host_runs.py shares the DDPG one)
TINY = {
    "ddpg": ["agent.hidden=[8,8]", "agent.learning_starts=10", "agent.buffer_size=200",
             "agent.batch_size=8"],
    "hi-ddpg": ["agent.high.hidden=[8,8]", "agent.low.hidden=[8,8]",
                "agent.learning_starts=10", "agent.high_learning_starts=2",
                "agent.pretrain_episodes=0", "agent.high.batch_size=2",
                "agent.low.batch_size=8"],
}
#: per algorithm, a loss that is positive once it learned and the parameters to compare
LEARNED = {"ddpg": ("critic_loss", lambda s: s.block),
           "hi-ddpg": ("low_critic_loss", lambda s: (s.low, s.high))}


def tiny_config(algo: str, episodes: list[str] = EPISODES):
    return make_config(algo, "PuckTrajectory1", "quick", episodes + TINY[algo])


def assert_close(got, want, what: str) -> None:
    """Every leaf of ``got`` is ``want``'s to float tolerance (the same tree structure)."""
    jax.tree_util.tree_map_with_path(
        lambda path, w, g: np.testing.assert_allclose(
            np.asarray(g), np.asarray(w), rtol=1e-5, atol=1e-6,
            err_msg=f"{what}{jax.tree_util.keystr(path)}"), want, got)


@pytest.mark.parametrize("algo", ["ddpg", "hi-ddpg"])
def test_one_seed_learns_as_in_the_jax_engine(algo):
    config = tiny_config(algo)
    jax_trainer = Trainer(config)
    host = make_trainer(dataclasses.replace(config, task=TASK))
    assert type(host).__name__ == "HostTrainer"
    keys = seed_keys([0])
    want_state, want_train, want_eval = jax_trainer.run_chunk_seeds(
        jax_trainer.init_seeds(keys), 2)
    state, train, evals = host.run_chunk_seeds(host.init_seeds(keys), 2)

    loss, params = LEARNED[algo]
    assert np.all(np.asarray(train[loss]) > 0)  # both episodes learned
    assert set(train) == set(want_train) and set(evals) == set(want_eval)
    assert_close(train, jax.device_get(want_train), "train metrics")
    assert_close(evals, jax.device_get(want_eval), "evaluation metrics")
    assert_close(params(state.agent), jax.device_get(params(want_state.agent)), "parameters")
    np.testing.assert_array_equal(np.asarray(state.key), np.asarray(want_state.key))

    eval_keys = seed_keys([7])
    metrics, traj = host.evaluate_seeds(state, eval_keys)
    want_metrics, want_traj = jax.device_get(jax_trainer.evaluate_seeds(want_state, eval_keys))
    assert set(traj) == set(want_traj)
    assert_close(metrics, want_metrics, "evaluation")
    assert_close(traj, want_traj, "trajectory")

"""Episodes on a foreign Gymnasium environment (:mod:`hiddpg.host.loop`): termination and
truncation as Gymnasium defines them, seeds whose episodes end at different steps, the affine
action map, and what reaches the replay buffer.

``Countdown`` ends its episode at a length ``L`` in 3..8 drawn at reset (terminated); its
``TimeLimit`` of 6 truncates the longer ones first. The observation ``[t, L, last action]``
shows, for every stored transition, whether the next observation is the true one (never a
reset's), whether the flag is right and which action the environment received."""

from __future__ import annotations

import dataclasses

import gymnasium as gym
import numpy as np
import pytest

from hiddpg.host import HostTrainer, register_gym_task, unregister_gym_task
from hiddpg.presets import make_config
from hiddpg.train import seed_keys

HORIZON, SEEDS, EPISODES = 6, [0, 1, 2, 3], 4


class Countdown(gym.Env):
    """Terminates after a random number of steps; the reward is the action received."""

    action_space = gym.spaces.Box(0.0, 4.0, (1,), np.float32)
    observation_space = gym.spaces.Box(-10.0, 10.0, (3,), np.float32)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.t, self.length = 0, int(self.np_random.integers(3, 9))
        return np.array([0.0, self.length, 0.0], np.float32), {}

    def step(self, action):
        assert self.action_space.contains(action), action
        self.t += 1
        received = float(action[0])
        obs = np.array([self.t, self.length, received], np.float32)
        return obs, received, self.t >= self.length, False, {}


@pytest.fixture(scope="module")
def trained():
    register_gym_task("Countdown", Countdown, max_episode_steps=HORIZON)
    config = make_config("ddpg", "PuckTrajectory1", "quick", [
        f"episodes={EPISODES}", f"eval_every={EPISODES}", f"chunk_episodes={EPISODES}",
        "agent.hidden=[8,8]", "agent.learning_starts=4", "agent.buffer_size=100",
        "agent.batch_size=4"])
    trainer = HostTrainer(dataclasses.replace(config, task="gym:Countdown"))
    state, train, evals = trainer.run_chunk_seeds(trainer.init_seeds(seed_keys(SEEDS)),
                                                  EPISODES)
    alone = trainer.run_chunk_seeds(trainer.init_seeds(seed_keys(SEEDS[2:3])), EPISODES)
    yield state, train, evals, alone
    unregister_gym_task("Countdown")


def test_seeds_end_at_their_own_steps(trained):
    _, train, evals, _ = trained
    lengths = train["length"]
    assert lengths.shape == (len(SEEDS), EPISODES)
    assert np.all((lengths >= 3) & (lengths <= HORIZON))
    assert any(len(set(lengths[:, e])) > 1 for e in range(EPISODES))  # masked seeds
    assert np.any(lengths == HORIZON) and np.any(lengths < HORIZON)
    np.testing.assert_array_equal(train["env_steps"], np.cumsum(lengths, axis=1))
    np.testing.assert_array_equal(train["episode"][0], np.arange(1, EPISODES + 1))
    np.testing.assert_array_equal(evals["episode"], [[EPISODES]] * len(SEEDS))


def test_the_replay_holds_the_true_transitions_with_gymnasiums_flags(trained):
    state, train, _, _ = trained
    buffers, truncated = state.agent.buffer, 0
    for i in range(len(SEEDS)):
        n = int(buffers.size[i])
        assert n == train["env_steps"][i, -1]  # nothing stored after an episode's end
        obs, nxt = np.asarray(buffers.data.obs[i, :n]), np.asarray(buffers.data.next_obs[i, :n])
        np.testing.assert_array_equal(nxt[:, 0], obs[:, 0] + 1)  # never a reset observation
        ended = nxt[:, 0] == nxt[:, 1]  # t == L: terminated, bootstraps no value
        np.testing.assert_array_equal(np.asarray(buffers.data.terminated[i, :n]), ended)
        assert np.sum(ended | (nxt[:, 0] == HORIZON)) == EPISODES  # truncated ones bootstrap
        truncated += np.sum(~ended & (nxt[:, 0] == HORIZON))
        unit = np.asarray(buffers.data.action[i, :n, 0])
        np.testing.assert_allclose(nxt[:, 2], 2.0 * (unit + 1.0), rtol=1e-6, atol=1e-6)
        np.testing.assert_array_equal(np.asarray(buffers.data.reward[i, :n]), nxt[:, 2])
        starts = np.concatenate([[0], np.cumsum(train["length"][i])])
        returns = [nxt[a:b, 2].sum() for a, b in zip(starts[:-1], starts[1:], strict=True)]
        np.testing.assert_allclose(train["return"][i], returns, rtol=1e-6)
    assert truncated > 0


def test_a_seed_learns_the_same_alone_and_among_others(trained):
    _, train, evals, (_, train_alone, evals_alone) = trained
    for key in train:
        np.testing.assert_array_equal(train[key][2:3], train_alone[key], err_msg=key)
    for key in evals:
        np.testing.assert_array_equal(evals[key][2:3], evals_alone[key], err_msg=key)

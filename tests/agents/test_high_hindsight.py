"""Hindsight actions for the high level (:class:`~hiddpg.configs.ActionHindsight`): a segment
enters D_H with the goal its low level reached (HAC's hindsight action transitions) in about
the given fraction (``probability``) of segments; a segment that ended in a collision keeps the
goal that led to it."""

from __future__ import annotations

import numpy as np
import pytest

from hiddpg.presets import make_config
from hiddpg.runs import make_trainer
from hiddpg.train import seed_keys


def _high_buffer(fraction: float, episodes: int = 12, *sets: str):
    """D_H of ArmObstacle after ``episodes`` training episodes (random goals and durations
    throughout, no learning): the stored goal entries (unit box) and the goal entries of each
    segment's last state, unit-scaled and clipped like the relabelled goals."""
    sets = ["agent.learning_starts=100000", "agent.pretrain_episodes=0",
            f"eval_every={episodes}", f"agent.high_hindsight.probability={fraction}", *sets]
    trainer = make_trainer(make_config("hi-ddpg", "ArmObstacle", "quick", sets))
    state, _, _ = trainer.run_chunk_seeds(trainer.init_seeds(seed_keys([0])), episodes)
    buf, space = state.agent.high.buffer, trainer.env.goal_space
    n = int(np.asarray(buf.size)[0])
    stored = np.asarray(buf.data.action)[0, :n, : space.dim]
    reached = np.clip(np.asarray(space.unscale(space.select(buf.data.next_obs[0, :n]))), -1, 1)
    collided = np.asarray(buf.data.reward)[0, :n] < -50  # the collision reward is -100
    return stored, reached, collided


def _is_reached(stored, reached):
    return np.all(np.abs(stored - reached) < 1e-6, axis=1)


def test_all_segments_store_the_goal_reached_but_collisions_keep_the_goal_set():
    # the obstacle grown from 0.04 m to 0.131 m, so that random movements hit it
    stored, reached, collided = _high_buffer(1.0, 30, "env.obstacle_diameter=0.131")
    assert (~collided).sum() >= 30 and collided.sum() >= 10, collided.sum()
    np.testing.assert_allclose(stored[~collided], reached[~collided], atol=1e-6)
    assert not _is_reached(stored[collided], reached[collided]).any()


def test_fraction_zero_stores_the_goals_set():
    stored, reached, _ = _high_buffer(0.0)
    # the goals set are uniform draws in the box; none ends exactly where its segment did
    assert not _is_reached(stored, reached).any()
    assert np.all(np.abs(stored) <= 1.0)


def test_about_the_fraction_is_relabelled():
    stored, reached, collided = _high_buffer(0.5, 30)
    share = _is_reached(stored[~collided], reached[~collided]).mean()
    assert (~collided).sum() >= 60
    assert 0.3 < share < 0.7, share


def test_the_fraction_must_be_a_probability():
    with pytest.raises(ValueError,
                       match=r"ActionHindsight.probability=-0.1 must lie in \[0, 1\]"):
        make_config("hi-ddpg", "ArmObstacle", "quick",
                    ["agent.high_hindsight.probability=-0.1"])

"""The best plans of the puck trajectory tasks for the reference controller
(hiddpg.experiments.plans): the reference plan is the optimum of PuckTrajectory1/2, not of
PuckTrajectory3 with the paper's switch cost."""

from __future__ import annotations

import functools

import numpy as np
import pytest

from hiddpg.envs import make as make_env
from hiddpg.experiments.plans import best_plans


@functools.cache
def _plans(task: str, max_goals: int):
    _, params = make_env(task)
    return {("ref" if p["reference"] else p["n_goals"]): p for p in best_plans(params, max_goals)}


def test_the_reference_plan_tracks_exactly_and_is_found_on_the_first_two_tasks():
    one = _plans("PuckTrajectory1", 2)
    assert one["ref"]["tracking"] > -1e-3 and one["ref"]["return"] > -1e-3
    assert one[1]["return"] > -0.05
    np.testing.assert_allclose(one[1]["goals"], one["ref"]["goals"], atol=0.02)
    assert one[2]["return"] < -9.9  # a switch costs 10 and cannot track better than exactly
    two = _plans("PuckTrajectory2", 2)
    assert abs(two["ref"]["return"] + 10.0) < 1e-3
    assert two[2]["switch_steps"] == [15] and two[2]["return"] > -10.05
    np.testing.assert_allclose(two[2]["goals"], two["ref"]["goals"], atol=0.05)
    assert two[1]["return"] < -20.0  # one goal is worse than the reference's switch


def test_fewer_goals_beat_the_reference_plan_of_the_third_task():
    """With the switch cost 10, two goals (one switch) and even one goal return more than the
    reference's three goals (two switches, -20): its switch count is not optimal."""
    three = _plans("PuckTrajectory3", 2)
    assert abs(three["ref"]["return"] + 20.0) < 1e-3
    assert three[2]["return"] > -18.1  # -17.97: better by about 2
    assert three[2]["switch_steps"] == [9]
    assert -19.2 < three[1]["return"] < -19.0  # -19.06
    with pytest.raises(ValueError, match="max_goals=0"):
        best_plans(make_env("PuckTrajectory3")[1], 0)

"""The critic-vs-truth probe of a run's first segment (hiddpg.experiments.probes)."""

from __future__ import annotations

import functools

import numpy as np
import pytest

from hiddpg.experiments.probes import add_end_values, end_value, end_value_table, first_segment
from hiddpg.presets import make_config
from hiddpg.runs import make_trainer
from hiddpg.train import eval_keys, seed_keys

SEEDS = [0, 3]


@functools.cache
def _setup():
    config = make_config("hi-ddpg", "PuckTrajectory1", "quick", ["agent.learning_starts=0"])
    trainer = make_trainer(config)
    state = trainer.init_seeds(seed_keys(SEEDS))
    return trainer, state


def test_the_actors_own_first_segment_is_the_evaluation_episode():
    """With the actor's own first action the probe's truth is exactly the evaluation's return;
    a duration covering the episode uses one goal and pays no switch cost; a one-step first
    segment pays it for every later goal."""
    trainer, state = _setup()
    keys = eval_keys(0, SEEDS)
    metrics, _ = trainer.evaluate_seeds(state, keys)
    out = first_segment(trainer, state, keys, [1.0, 30.0])
    np.testing.assert_allclose(out["policy"]["return"], np.asarray(metrics["return"]),
                               rtol=1e-6, atol=1e-5)
    assert out["return"].shape == out["q"].shape == (2, 2)
    np.testing.assert_array_equal(out["goals"][:, 1], 1)
    np.testing.assert_allclose(out["return"][:, 1], out["env_return"][:, 1], rtol=1e-6)
    assert np.all(out["goals"][:, 0] >= 2)
    cost = trainer.agent.config.switch_cost
    np.testing.assert_allclose(out["return"][:, 0],
                               out["env_return"][:, 0] - cost * (out["goals"][:, 0] - 1),
                               rtol=1e-5, atol=1e-4)


def test_the_policy_is_the_hold_choice_on_either_side():
    """The preset holds where the critic prefers it; with the critic's sign flipped every
    choice flips, and the probe's policy still reproduces the evaluation exactly."""
    trainer, state = _setup()
    assert trainer.agent.config.choice.kind == "hold"
    keys = eval_keys(0, SEEDS)
    critic = state.agent.high.block.critic
    flipped = {"params": dict(critic["params"],
                              out={k: -v for k, v in critic["params"]["out"].items()})}
    high = state.agent.high.replace(block=state.agent.high.block.replace(critic=flipped))
    durations = []
    for st in (state, state.replace(agent=state.agent.replace(high=high))):
        metrics, _ = trainer.evaluate_seeds(st, keys)
        out = first_segment(trainer, st, keys, [30.0])
        np.testing.assert_allclose(out["policy"]["return"], np.asarray(metrics["return"]),
                                   rtol=1e-6, atol=1e-5)
        durations.append(np.asarray(out["policy"]["duration"]) >= 29.5)
    np.testing.assert_array_equal(durations[0], ~durations[1])  # held on exactly one side


def test_a_given_goal_replaces_the_actors_and_bad_durations_are_refused():
    trainer, state = _setup()
    keys = eval_keys(0, SEEDS)
    own = first_segment(trainer, state, keys, [30.0])
    ref = first_segment(trainer, state, keys, [30.0], goal=[1.5, 0.35])
    np.testing.assert_allclose(ref["first_goal"][:, 0], [[1.5, 0.35]] * len(SEEDS), atol=1e-5)
    np.testing.assert_allclose(own["first_goal"][:, 0], own["policy"]["goal"], atol=1e-6)
    # one goal held all episode: the end state differs with the goal, so does the return
    assert not np.allclose(own["env_return"], ref["env_return"])
    np.testing.assert_allclose(ref["policy"]["return"], own["policy"]["return"])
    with pytest.raises(ValueError, match=r"durations \[0.5\].*\[1.0, 30.0\]"):
        first_segment(trainer, state, keys, [0.5])


def test_the_end_value_starts_at_the_evaluations_first_value_and_ends_where_it_ends():
    """``q_start`` is the evaluation's own ``high_q_start`` (computed inside the episode);
    ``q_end`` is the critic at the state the episode ends in: moving the critic's output bias
    by ``c`` moves both by ``c``, and the episode (PuckObstacle, truncated at its horizon
    unless the puck hits the obstacle) is the evaluation's."""
    config = make_config("hi-ddpg", "PuckObstacle", "paper",
                         ["agent.high.hidden=[16,16]", "agent.low.hidden=[16,16]"])
    trainer = make_trainer(config)
    state = trainer.init_seeds(seed_keys(SEEDS))
    keys = eval_keys(0, SEEDS)
    metrics, traj = trainer.evaluate_seeds(state, keys)
    out = end_value(trainer, state, keys)
    np.testing.assert_allclose(out["q_start"], np.asarray(metrics["high_q_start"]), rtol=1e-6,
                               atol=1e-6)
    np.testing.assert_array_equal(out["steps"], np.asarray(traj["alive"]).sum(axis=1))
    horizon = trainer.env.max_steps(trainer.env_params)
    np.testing.assert_array_equal(out["ended_early"], out["steps"] < horizon)
    np.testing.assert_array_equal(out["goals"], np.asarray(traj["switch"]).sum(axis=1))
    np.testing.assert_allclose(out["env_return"], np.asarray(metrics["env_return"]), rtol=1e-6)
    critic = state.agent.high.block.critic
    bias = critic["params"]["out"]["bias"]
    moved = {"params": dict(critic["params"], out=dict(critic["params"]["out"], bias=bias + 7.0))}
    high = state.agent.high.replace(block=state.agent.high.block.replace(critic=moved))
    shifted = end_value(trainer, state.replace(agent=state.agent.replace(high=high)), keys)
    np.testing.assert_allclose(shifted["q_end"], out["q_end"] + 7.0, rtol=1e-5, atol=1e-4)
    np.testing.assert_allclose(shifted["q_start"], out["q_start"] + 7.0, rtol=1e-5, atol=1e-4)
    with pytest.raises(ValueError, match="end_value probes HI-DDPG runs, not DDPG"):
        end_value(make_trainer(make_config("ddpg", "PuckObstacle", "paper")), state, keys)


def test_an_export_replaces_its_own_label_only():
    """Two studies' run directories share a name (names hold no seeds): both rows stay."""
    def entry(label, seed, q):
        row = {"ended_early": False, "env_return": -14.0, "goals": 4, "last_reward": -0.15,
               "q_end": q, "q_start": q, "steps": 75}
        return {"run": label, "name": "hi-ddpg-ArmObstacle-paper+-e3257ee6", "episodes": 2000,
                "eval_key": 0, "seeds": {str(seed): row}}

    record = add_end_values({"runs": []}, entry("paper+, seeds 200-204", 200, -110.0))
    record = add_end_values(record, entry("paper+, seeds 105-109", 105, -120.0))
    assert [r["run"] for r in record["runs"]] == ["paper+, seeds 200-204", "paper+, seeds 105-109"]
    record = add_end_values(record, entry("paper+, seeds 200-204", 200, -90.0))
    assert [r["run"] for r in record["runs"]] == ["paper+, seeds 105-109", "paper+, seeds 200-204"]
    table = end_value_table(record)
    row = "| paper+, seeds 200-204 | 2000 | 200 | 75 | 4 | -14.0 | -0.150 | -90.0 | -90.0 |"
    assert row in table
    assert "-110.0" not in table and "-120.0" in table

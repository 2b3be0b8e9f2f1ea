"""The configs of HI-DDPG's parts: selected and set with ``--set``, validated, and kept
through ``config.json`` (to_dict / from_dict)."""

from __future__ import annotations

import json

import pytest

from hiddpg.configs import (
    ActionHindsight,
    ActorChoice,
    CriticDurations,
    GoalHindsight,
    HoldChoice,
    HuberLoss,
    RestTerm,
    from_dict,
    to_dict,
)
from hiddpg.presets import make_config


def _agent(*sets: str):
    return make_config("hi-ddpg", "PuckTrajectory2", "quick", list(sets)).agent


def test_the_paper_has_every_part_off():
    agent = make_config("hi-ddpg", "PuckObstacle", "paper").agent
    assert agent.choice == ActorChoice()
    assert (agent.low_hindsight, agent.high_hindsight, agent.rest_term) == (None, None, None)
    assert agent.high.huber is None and agent.low.huber is None


def test_a_choice_is_selected_by_its_kind_and_its_keys_set_after():
    assert _agent().choice == HoldChoice(explore=0.1)  # the trajectory tasks' preset
    assert _agent("agent.choice=actor").choice == ActorChoice()
    assert _agent("agent.choice=critic-durations").choice == CriticDurations(explore=0.5)
    got = _agent("agent.choice=critic-durations", "agent.choice.explore=0.25").choice
    assert got == CriticDurations(explore=0.25)


def test_an_optional_part_is_created_by_setting_a_key_and_removed_by_none():
    agent = _agent("agent.low_hindsight.fraction=0.3", "agent.high.huber.delta=2",
                   "agent.rest_term={}", "agent.high_hindsight.probability=0.5")
    assert agent.low_hindsight == GoalHindsight(fraction=0.3)
    assert agent.high.huber == HuberLoss(delta=2.0) and agent.low.huber is None
    assert agent.rest_term == RestTerm(weight=0.3)
    assert agent.high_hindsight == ActionHindsight(probability=0.5)
    assert _agent("agent.rest_term={}", "agent.rest_term=none").rest_term is None


@pytest.mark.parametrize("sets, message", [
    (["agent.choice=hold-on"], r"'hold-on' is not allowed; choose one of \['actor', 'hold', "
                               r"'critic-durations'\]"),
    (["agent.choice=none"], "agent.choice: cannot be none"),
    (["agent.choice=actor", "agent.choice.explore=0.5"], "unknown key 'explore' in ActorChoice"),
    (["agent.low_hindsight.fraction=1.5"], r"GoalHindsight.fraction=1.5 must lie in \[0, 1\]"),
    (["agent.high.huber.delta=0"], "HuberLoss.delta=0.0 must be a finite number > 0"),
    (["agent.high.huber.late_delta=3"], "HuberLoss.late_episode=0 must be an int >= 1"),
    (["agent.rest_term.weight=-1"], "RestTerm.weight=-1.0 must be a finite number >= 0"),
    (["agent.choice.explore=0", "agent.choice=critic-durations"],
     "comes after --set agent.choice.explore=...: set agent.choice first"),
    (["agent.choice=critic-durations", "agent.duration_max=1.5"],
     "needs at least two integer durations"),
])
def test_bad_parts_are_refused_with_the_value_named(sets, message):
    with pytest.raises(ValueError, match=message):
        _agent(*sets)


def test_parts_survive_the_json_round_trip():
    cfg = make_config("hi-ddpg", "ArmObstacle", "quick", [
        "agent.choice=critic-durations", "agent.high.huber.delta=10",
        "agent.high.huber.late_delta=3", "agent.high.huber.late_episode=20",
        "agent.low_hindsight.fraction=0.8", "agent.high_hindsight.probability=1"])
    assert from_dict(json.loads(json.dumps(to_dict(cfg)))) == cfg


def test_a_config_of_another_version_names_the_unknown_field():
    data = to_dict(make_config("hi-ddpg", "PuckTrajectory1", "quick"))
    data["agent"]["hold_explore"] = 0.1
    with pytest.raises(ValueError, match=r"HIDDPGConfig has no field\(s\) \['hold_explore'\]"):
        from_dict(data)
    data = to_dict(make_config("hi-ddpg", "PuckTrajectory1", "quick"))
    data["agent"]["choice"]["_type"] = "ArgmaxChoice"
    with pytest.raises(ValueError, match="config type 'ArgmaxChoice' is unknown"):
        from_dict(data)

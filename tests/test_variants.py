"""Variants ``paper`` and ``paper+``: what each named change touches, and that ``paper+`` is
``paper`` with exactly :data:`PAPER_PLUS` made, for every algorithm."""

from __future__ import annotations

import dataclasses

import jax
import numpy as np
import pytest

from hiddpg import variants
from hiddpg.commands.train import DEFAULT_SEEDS
from hiddpg.configs import EagerHighLevel
from hiddpg.presets import PRESETS, make_config

ALGOS = ("ddpg", "hi-ddpg", "hi-ddpg-wo-model", "h-ddpg")
TASKS = ("PuckTrajectory2", "PuckObstacle", "ArmObstacle")


def diff(a, b, prefix=""):
    """Dotted paths of the leaf fields where two configs differ."""
    if dataclasses.is_dataclass(a) and dataclasses.is_dataclass(b) and type(a) is type(b):
        out = []
        for f in dataclasses.fields(a):
            out += diff(getattr(a, f.name), getattr(b, f.name), f"{prefix}{f.name}.")
        return out
    return [] if a == b else [prefix.rstrip(".")]


#: (change, algorithm) -> the fields it must set, and nothing else.
EXPECTED = {
    "tau-0.01": {"ddpg": ["tau"], "hi-ddpg": ["high.tau", "low.tau"],
                 "h-ddpg": ["skill.tau"]},
    "invert-gradients": {"ddpg": ["invert_gradients"],
                         "hi-ddpg": ["high.invert_gradients", "low.invert_gradients"],
                         "h-ddpg": ["skill.invert_gradients"]},
    "action-l2": {"ddpg": ["action_l2"], "hi-ddpg": ["high.action_l2", "low.action_l2"],
                  "h-ddpg": ["skill.action_l2"]},
    "linear-output": {"ddpg": ["actor_output"],
                      "hi-ddpg": ["high.actor_output", "low.actor_output"],
                      "h-ddpg": ["skill.actor_output"]},
    "lr-x5": {"ddpg": ["actor_lr", "critic_lr"], "hi-ddpg": ["high.lr", "low.lr"],
              "h-ddpg": ["skill.actor_lr", "skill.critic_lr"]},
    "lr-1e-3": {"ddpg": ["actor_lr"], "hi-ddpg": ["high.lr", "low.lr"],  # critics: 1e-3
                "h-ddpg": ["skill.actor_lr"]},
    "high-every-step": {"ddpg": [], "hi-ddpg": ["eager_high"], "h-ddpg": []},
    "low-through-termination": {"ddpg": [], "hi-ddpg": ["low.env_terminal"], "h-ddpg": []},
    "episode-end-terminal": {"ddpg": ["end_is_terminal"], "hi-ddpg": ["high.end_is_terminal"],
                             "h-ddpg": ["skill.end_is_terminal"]},
}


@pytest.mark.parametrize("name", sorted(EXPECTED))
@pytest.mark.parametrize("algo", ["ddpg", "hi-ddpg", "h-ddpg"])
def test_each_change_sets_its_fields_in_every_block_and_nothing_else(name, algo):
    paper = make_config(algo, "ArmObstacle", "paper").agent
    changed = variants.apply_changes(paper, [name])
    assert diff(paper, changed) == EXPECTED[name][algo]


def test_changes_set_the_values_they_name():
    paper = make_config("hi-ddpg", "PuckTrajectory2", "paper").agent
    get = variants.apply_changes
    assert get(paper, ["tau-0.01"]).low.tau == 0.01
    assert get(paper, ["lr-x5"]).high.lr == pytest.approx(5 * paper.high.lr)
    assert get(paper, ["lr-x25"]).low.lr == pytest.approx(25 * paper.low.lr)
    assert (get(paper, ["lr-1e-3"]).high.lr, get(paper, ["lr-1e-3"]).low.lr) == (1e-3, 1e-3)
    assert get(paper, ["high-every-step"]).eager_high == EagerHighLevel(every_step=True)
    assert get(paper, ["linear-output"]).high.actor_output == "linear"
    assert get(paper, ["action-l2"]).low.action_l2 == 1.0
    assert get(paper, ["invert-gradients"]).high.invert_gradients is True
    assert get(paper, ["low-through-termination"]).low.env_terminal is False
    assert get(paper, ["low-through-termination"]).high.env_terminal is True
    ended = get(paper, ["episode-end-terminal"])
    assert (ended.high.end_is_terminal, ended.low.end_is_terminal) == (True, False)
    # h-DDPG's meta-critic is not an actor-critic block: its rate stays
    h = make_config("h-ddpg", "PuckObstacle", "paper").agent
    assert get(h, ["lr-x5"]).meta == h.meta


def test_unknown_change_names_the_known_ones():
    with pytest.raises(ValueError, match=r"unknown change 'tau'; choose from \['action-l2'"):
        variants.apply_changes(make_config("ddpg", "PuckObstacle").agent, ["tau"])
    with pytest.raises(ValueError, match=r"unknown variant 'paper\+\+'"):
        variants.describe("paper++")


@pytest.mark.parametrize("algo", ALGOS)
def test_paper_plus_is_paper_with_exactly_its_changes(algo):
    for task in TASKS:
        plus = make_config(algo, task, "paper+")
        paper = make_config(algo, task, "paper")
        want = variants.apply_changes(paper.agent, variants.PAPER_PLUS)
        assert plus.agent == want
        assert (plus.episodes, plus.eval_every, plus.chunk_episodes) == (
            paper.episodes, paper.eval_every, paper.chunk_episodes)
        assert plus.preset == "paper+"


def test_paper_plus_is_a_preset_with_the_papers_seeds():
    assert "paper+" in PRESETS and DEFAULT_SEEDS["paper+"] == DEFAULT_SEEDS["paper"] == "0-14"
    assert variants.describe("paper") == "paper: the paper as written"
    words = variants.describe("paper+")
    for name in variants.PAPER_PLUS:
        assert variants.CHANGES[name].what in words


def test_a_variant_that_adds_nothing_trains_nothing(tmp_path, capsys, monkeypatch):
    """While PAPER_PLUS is empty, paper+ is paper: reproduce says so and writes nothing."""
    from hiddpg.commands import reproduce

    monkeypatch.setitem(variants.VARIANTS, "paper+", ())
    assert variants.same_as("paper+") == "paper" and variants.same_as("paper") is None
    out = tmp_path / "out"
    assert reproduce.main(["fig3", "--scale", "paper", "--variant", "paper+",
                           "--out", str(out)]) == 0
    assert "adds no change to paper" in capsys.readouterr().out and not out.exists()
    monkeypatch.setitem(variants.VARIANTS, "paper+", ("tau-0.01",))
    assert variants.same_as("paper+") is None


MEASURED_SECOND_CANDIDATE = (
    "agent.eager_high.every_step=true", "agent.low.env_terminal=false", "agent.high.lr=1e-3",
    "agent.low.lr=1e-3", "agent.high.invert_gradients=true", "agent.low.invert_gradients=true",
    "agent.high.action_l2=1", "agent.low.action_l2=1")


#: what studies/paper-plus-arm-seeds.toml adds to paper+ of the time (episode-end-terminal)
MEASURED_END = ("agent.high.end_is_terminal=true",)


@pytest.mark.parametrize("task", ["PuckTrajectory2", "ArmObstacle"])
def test_paper_plus_is_the_set_the_diagnosis_measured(task):
    """HI-DDPG's paper+ is exactly the second candidate of docs/diagnosis-puck.md (the overrides of
    studies/paper-plus-puck-seeds.toml and studies/paper-plus-candidate-2.toml) with the high
    level's value ending at the time limit (studies/paper-plus-arm-seeds.toml), so its
    measured numbers are paper+'s."""
    measured = make_config("hi-ddpg", task, "paper",
                           list(MEASURED_SECOND_CANDIDATE + MEASURED_END))
    plus = make_config("hi-ddpg", task, "paper+")
    assert plus.agent == measured.agent
    assert plus.agent != make_config("hi-ddpg", task, "paper").agent


def test_episode_end_terminal_trains_the_same_on_a_trajectory_task():
    """PuckTrajectory2 terminates at its horizon and never truncates, so paper+'s numbers
    measured there without `episode-end-terminal` are its numbers with it: bit for bit."""
    from hiddpg.runs import make_trainer
    from hiddpg.train import seed_keys

    tiny = ["episodes=6", "eval_every=3", "agent.learning_starts=32",
            "agent.high_learning_starts=8", "agent.high.batch_size=8", "agent.low.batch_size=8"]
    out = []
    for end in ("false", "true"):
        config = make_config("hi-ddpg", "PuckTrajectory2", "paper",
                             list(MEASURED_SECOND_CANDIDATE) + tiny
                             + [f"agent.high.end_is_terminal={end}"])
        trainer = make_trainer(config)
        state, train_metrics, _ = trainer.run_chunk_seeds(trainer.init_seeds(seed_keys([0])), 6)
        out.append((state.agent, train_metrics["return"]))
    (a, ra), (b, rb) = out
    assert np.asarray(ra).shape == (1, 6)
    for x, y in zip(jax.tree.leaves(a), jax.tree.leaves(b), strict=True):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))

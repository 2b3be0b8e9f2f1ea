"""``--set key=value`` with a non-finite number: one message, whatever the spelling, for every
numeric field and every environment parameter; finite numbers still pass."""

from __future__ import annotations

import pytest

from hiddpg.commands import train as train_cmd
from hiddpg.presets import make_config

NAN_SPELLINGS = ["nan", "NaN", "NAN", "-nan", '"nan"']
INF_SPELLINGS = ["inf", "Infinity", "+inf", "1e999", '"inf"']
NEG_INF_SPELLINGS = ["-inf", "-Infinity", "-1e999"]
SPELLINGS = ([(s, "nan") for s in NAN_SPELLINGS] + [(s, "inf") for s in INF_SPELLINGS]
             + [(s, "-inf") for s in NEG_INF_SPELLINGS])

# (algorithm, key): float fields at different depths, an int field and an environment parameter
FIELDS = [
    ("ddpg", "agent.actor_lr"),
    ("ddpg", "agent.noise.sigma"),
    ("hi-ddpg", "agent.switch_cost"),
    ("hi-ddpg", "agent.low.lr"),
    ("ddpg", "episodes"),
    ("ddpg", "env.dt"),
]


@pytest.mark.parametrize("algo,key", FIELDS)
@pytest.mark.parametrize("spelling,shown", SPELLINGS)
def test_every_spelling_of_a_non_finite_number_gives_one_message(algo, key, spelling, shown):
    with pytest.raises(ValueError) as err:
        make_config(algo, "PuckTrajectory1", "quick", [f"{key}={spelling}"])
    assert str(err.value) == f"--set {key}={shown}: must be a finite number"


@pytest.mark.parametrize("algo,key,value,read", [
    ("ddpg", "agent.actor_lr", "3e-4", 3e-4),
    ("ddpg", "agent.noise.sigma", "1e300", 1e300),
    ("hi-ddpg", "agent.switch_cost", "-2.5", -2.5),
    ("ddpg", "episodes", "20", 20),
])
def test_finite_numbers_still_pass(algo, key, value, read):
    cfg = make_config(algo, "PuckTrajectory1", "quick", [f"{key}={value}"])
    obj = cfg
    for name in key.split("."):
        obj = getattr(obj, name)
    assert obj == read


def test_a_string_field_may_hold_a_word_that_spells_a_number():
    cfg = make_config("ddpg", "PuckTrajectory1", "quick", ["preset=inf"])
    assert cfg.preset == "inf"


@pytest.mark.parametrize("spelling", ["nan", "NaN", "inf", "-Infinity"])
def test_the_command_line_prints_the_message_and_exits_2(spelling, tmp_path, capsys):
    argv = ["ddpg", "PuckTrajectory1", "--preset", "quick", "--seeds", "0",
            "--set", f"agent.actor_lr={spelling}", "--out", str(tmp_path)]
    assert train_cmd.main(argv) == 2
    shown = "-inf" if spelling.startswith("-") else spelling.lower()
    assert capsys.readouterr().err.strip() == (
        f"hiddpg train: error: --set agent.actor_lr={shown}: must be a finite number")
    assert list(tmp_path.iterdir()) == []

"""``hiddpg eval``'s table: the columns ``return`` / ``env_return`` / ``switches`` / ``length``
per seed, their mean and std over seeds, and a line saying what ``return`` and ``env_return``
are (the GIF's running number is ``env_return``). A fake run and trainer stand in for a trained
one (the end-to-end replay is in ``test_train_cli.py``)."""

from __future__ import annotations

import argparse
from types import SimpleNamespace

import numpy as np
import pytest

from hiddpg.commands import eval as eval_cmd

METRICS = {"return": np.array([-30.0, -20.0, -10.0]), "env_return": np.array([-20.0, -10.0, 0.0]),
           "switches": np.array([1, 1, 1]), "length": np.array([30, 30, 30])}


def table(capsys, seed=None) -> list[str]:
    trainer = SimpleNamespace(evaluate_seeds=lambda state, keys: (METRICS, {}))
    run = SimpleNamespace(seeds=(0, 1, 2),
                          config=SimpleNamespace(algo="hi-ddpg", task="PuckTrajectory2"))
    args = argparse.Namespace(seed=seed, key=0, gif=None)
    assert eval_cmd._evaluate(args, (run, trainer, None, 40)) == 0
    return capsys.readouterr().out.splitlines()


def test_columns_mean_std_and_what_they_are(capsys):
    lines = table(capsys)
    assert lines[1].split() == ["seed", "return", "env_return", "switches", "length"]
    assert lines[3].split() == ["1", "-20.000", "-10.000", "1", "30"]
    mean = lines[5].split()
    assert mean[0] == "mean" and [float(v) for v in mean[1:]] == [-20.0, -10.0, 1.0, 30.0]
    std = lines[6].split()
    assert std[0] == "std" and float(std[1]) == pytest.approx(10.0)
    note = lines[-1]
    assert note == eval_cmd.COLUMN_NOTE
    assert "return: " in note and "env_return: the sum of the environment's rewards" in note
    assert "GIF" in note


def test_one_seed_has_no_mean_row(capsys):
    lines = table(capsys, seed=2)
    assert [line.split()[0] for line in lines[2:-1]] == ["2"]

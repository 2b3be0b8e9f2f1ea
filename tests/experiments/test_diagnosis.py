"""The one-change-at-a-time table (hiddpg.experiments.diagnosis) from runs written with known
numbers: the last evaluation and the last-window training means, per run, named by the
changes sweep.json lists."""

from __future__ import annotations

import json

import numpy as np
import pytest

from hiddpg.experiments import diagnosis
from hiddpg.presets import make_config
from hiddpg.runs import Run

SEEDS = (100, 101)


def write_run(path, shift: float):
    """40 episodes; env_return of seed i at episode e is shift + e / 10 + i; evaluations at
    episodes 20 and 40 return shift + episode + i."""
    run = Run.create(path, make_config("hi-ddpg", "PuckTrajectory2", "paper"), SEEDS)
    episodes = np.tile(np.arange(1, 41), (2, 1))
    seed_offset = np.array([[0.0], [1.0]])
    train = {"episode": episodes, "env_return": shift + episodes / 10 + seed_offset,
             "return": shift - 5 + episodes * 0.0 + seed_offset, "length": np.full((2, 40), 30),
             "reach_error": np.full((2, 40), 0.25), "switches": np.ones((2, 40))}
    evals = {"episode": np.array([[20, 40], [20, 40]]),
             "env_return": shift + np.array([[20.0, 40.0], [21.0, 41.0]]),
             "switches": np.array([[1.0, 2.0], [1.0, 4.0]])}
    run.append_metrics(train, evals)
    run.close()


def test_rows_hold_the_last_evaluation_and_the_last_window(tmp_path):
    write_run(tmp_path / "a", 0.0)
    write_run(tmp_path / "b", -100.0)
    (tmp_path / "sweep.json").write_text(json.dumps({"runs": {
        "a": {"preset": "paper", "sets": []},
        "b": {"preset": "paper", "sets": ["agent.high.lr=0.0001", "agent.low.lr=0.001"]}}}))
    rows = diagnosis.summarize([str(tmp_path)], window=10)
    assert [r["run"] for r in rows] == ["paper", "agent.high.lr=0.0001, agent.low.lr=0.001"]
    a, b = rows
    assert a["episodes"] == 40 and a["seeds"] == 2
    assert a["eval_env_return"] == pytest.approx((40.5, np.std([40, 41], ddof=1)))
    assert b["eval_env_return"][0] == pytest.approx(-59.5)
    assert a["eval_switches"] == pytest.approx((3.0, np.std([2, 4], ddof=1)))
    # last 10 episodes: e = 31..40, mean e / 10 = 3.55; seeds 3.55 and 4.55
    assert a["env_return"] == pytest.approx((4.05, np.std([3.55, 4.55], ddof=1)))
    assert a["reach_error"] == pytest.approx((0.25, 0.0))
    assert "high_q_mean" not in a
    table = diagnosis.markdown(rows).splitlines()
    assert table[0].startswith("| run | episodes | seeds | eval_env_return | eval_switches")
    assert "high_q_mean" not in table[0]
    assert table[2].startswith("| paper | 40 | 2 | 40.5 ± 0.71 |")

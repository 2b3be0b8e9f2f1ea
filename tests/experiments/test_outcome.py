"""Where a final policy ends (hiddpg.experiments.outcome): success, early end and last reward
from hand-made episodes, and from a run's checkpoint, whose replayed episode is the run's own
logged evaluation at that episode (ArmObstacle is deterministic), in the diagnosis table."""

from __future__ import annotations

import numpy as np
import pytest

from hiddpg.experiments import diagnosis
from hiddpg.experiments.outcome import episode_outcomes, final_outcome, summary
from hiddpg.presets import make_config
from hiddpg.runner import prepare_new, train_run
from hiddpg.runs import make_trainer

HORIZON = 5


def episodes(rewards: list[list[float]], steps: list[int]) -> dict[str, np.ndarray]:
    alive = np.array([[t < n for t in range(HORIZON)] for n in steps])
    return {"alive": alive, "reward": np.array(rewards)}


def test_success_needs_the_horizon_and_the_last_reward_within_the_radius():
    traj = episodes([[-0.5, -0.3, -0.1, -0.05, -0.02],   # ends within 0.03: success
                     [-0.5, -0.3, -0.1, -0.05, -0.04],   # stops short
                     [-0.5, -0.4, -100.0, 0.0, 0.0],     # collides at its third step
                     [-0.5, -0.4, 0.0, 0.0, 0.0]],       # collides, collision reward 0
                    [5, 5, 3, 3])
    out = episode_outcomes(traj, HORIZON, 0.03)
    assert out["success"] == [True, False, False, False]
    assert out["ended_early"] == [False, False, True, True]
    assert out["final_reward"] == pytest.approx([-0.02, -0.04, -100.0, 0.0])
    assert out["env_return"] == pytest.approx([-0.97, -0.99, -100.9, -0.9])
    cells = summary({"seeds": [0, 1, 2, 3], **out})
    assert cells["final_success"] == (1, 4) and cells["final_ended_early"] == (2, 4)
    assert cells["final_reward"][0] == pytest.approx(np.mean([-0.02, -0.04, -100.0, 0.0]))


def test_a_task_without_a_success_criterion_has_none():
    out = episode_outcomes(episodes([[-1.0] * HORIZON], [HORIZON]), HORIZON, None)
    assert out["success"] == [None] and out["ended_early"] == [False]
    assert "final_success" not in summary({"seeds": [0], **out})


@pytest.fixture(scope="module")
def arm_run(tmp_path_factory):
    config = make_config("ddpg", "ArmObstacle", "quick",
                         ["episodes=20", "eval_every=10", "chunk_episodes=10",
                          "agent.hidden=[16,16]", "agent.learning_starts=50"])
    path = tmp_path_factory.mktemp("outcome") / "arm"
    train_run(prepare_new(config, [3, 4], path), make_trainer(config))
    return path


def test_the_replayed_episode_is_the_runs_logged_evaluation(arm_run):
    final = final_outcome(arm_run, 20)
    assert final["seeds"] == [3, 4] and final["episodes"] == 20
    logged = diagnosis.collect([str(arm_run)])["runs"][0]
    assert logged["eval_episodes"][-1] == 20
    last_eval = np.asarray(logged["eval"]["eval_env_return"])[:, -1]
    assert final["env_return"] == pytest.approx(last_eval, rel=1e-5, abs=1e-5)
    rows = diagnosis.summarize([str(arm_run)], final=True)
    n_success = sum(final["success"])
    assert rows[0]["final_success"] == (n_success, 2)
    table = diagnosis.markdown(rows)
    assert "final_success | final_ended_early | final_reward" in table
    assert f"| {n_success}/2 | {sum(final['ended_early'])}/2 |" in table


def test_an_exported_study_keeps_the_outcome(arm_run, tmp_path, capsys):
    export = tmp_path / "study.json"
    assert diagnosis.main([str(arm_run), "--at", "20", "--final", "--export", str(export)]) == 0
    printed = capsys.readouterr().out
    rows = diagnosis.summarize([str(export)])
    assert rows[0]["final_reward"][0] == pytest.approx(np.mean(final_outcome(arm_run, 20)
                                                              ["final_reward"]))
    assert diagnosis.markdown(rows) in printed


def test_an_outcome_at_another_episode_than_the_checkpoint_is_refused(arm_run, capsys):
    with pytest.raises(ValueError, match="checkpoint holds 20 episodes, not 10"):
        final_outcome(arm_run, 10)
    assert diagnosis.main([str(arm_run), "--at", "10", "--final"]) == 2
    assert "not 10" in capsys.readouterr().err

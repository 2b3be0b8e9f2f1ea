"""HI-DDPG on a real MuJoCo task through the ``hiddpg`` entry point: ``Reacher-v5`` with the
fingertip-to-target entries of its observation (8 and 9) as the goal, declared on the command
line. The run directory records the declaration, a run stopped after its first chunk and
resumed in a process that no longer holds the declaration ends with the uninterrupted run's
files (MuJoCo is deterministic given the reset seed), and two evaluations print the same
finite numbers. Needs the ``mujoco`` extra (in ``dev``, so CI runs it)."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("mujoco")

from hiddpg import cli  # noqa: E402
from hiddpg.commands import train as train_cmd  # noqa: E402
from hiddpg.host import GYM_TASKS  # noqa: E402

TINY = ["--seeds", "0-1", "--episodes", "4", "--set", "eval_every=2",
        "--set", "chunk_episodes=2", "--set", "agent.high.hidden=[8,8]",
        "--set", "agent.low.hidden=[8,8]", "--set", "agent.pretrain_episodes=0",
        "--set", "agent.learning_starts=40", "--set", "agent.high_learning_starts=4",
        "--set", "agent.high.batch_size=4", "--set", "agent.low.batch_size=8"]
ARGV = ["hi-ddpg", "Reacher-v5", "--goal", "8:-0.3:0.3", "--goal", "9:-0.3:0.3", *TINY]


@pytest.fixture(scope="module")
def reacher(tmp_path_factory):
    """``ref``: 4 episodes of seeds 0-1; ``cut``: the same stopped after its first chunk, then
    ``hiddpg train --resume``."""
    out = tmp_path_factory.mktemp("reacher")
    assert cli.main(["train", *ARGV, "--out", str(out), "--name", "ref"]) == 0

    def stop(run, episodes):
        raise KeyboardInterrupt

    assert train_cmd.main([*ARGV, "--out", str(out), "--name", "cut"], on_chunk=stop) == 130
    assert "Reacher-v5" not in GYM_TASKS  # as in a fresh process: only config.json has it
    assert cli.main(["train", "--resume", str(out / "cut")]) == 0
    return out


def test_reacher_run_resume_and_eval(reacher, capsys):
    ref, cut = reacher / "ref", reacher / "cut"
    meta = json.loads((ref / "config.json").read_text())
    assert meta["config"]["task"] == "gym:Reacher-v5"
    assert meta["gym_task"]["goal"] == {"8": [-0.3, 0.3], "9": [-0.3, 0.3]}
    assert meta["sources"]["environment"]["horizon"] == 50
    assert json.loads((ref / "progress.json").read_text())["status"] == "finished"
    rows = (ref / "metrics.csv").read_text().splitlines()
    header = rows[0].split(",")
    assert len(rows) == 1 + 2 * 4 and {"high_critic_loss", "eval_env_return"} <= set(header)
    steps = [int(r.split(",")[2]) for r in rows[1:]]
    assert steps == [50, 50, 100, 100, 150, 150, 200, 200]  # Reacher never terminates early
    for name in ("metrics.csv", "checkpoint.msgpack"):
        assert (cut / name).read_bytes() == (ref / name).read_bytes()
    capsys.readouterr()
    tables = []
    for _ in range(2):
        assert cli.main(["eval", str(ref)]) == 0
        out = capsys.readouterr().out.splitlines()
        tables.append([[float(v) for v in line.split()[1:]] for line in out
                       if line.split() and line.split()[0] in ("0", "1")])
    first = np.array(tables[0])
    assert first.shape == (2, 4) and np.all(np.isfinite(first)) and tables[1] == tables[0]
    assert list(first[:, 3]) == [50, 50] and np.all(first[:, 1] < 0)  # length; distance costs

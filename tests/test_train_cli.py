"""``hiddpg train`` end to end on small budgets: determinism, resume, seed independence,
config errors (exit 2, nothing written) and non-finite losses (exit 1, last checkpoint kept)."""

from __future__ import annotations

import json
import os
import shutil

import numpy as np
import pytest

from hiddpg import runs
from hiddpg.commands import train as train_cmd
from hiddpg.presets import make_config

QUICK = ["--preset", "quick", "--set", "episodes=20", "--set", "eval_every=10",
         "--set", "chunk_episodes=10", "--set", "agent.hidden=[16,16]",
         "--set", "agent.learning_starts=50"]
TASK = "PuckTrajectory1"


def train(out, name, *extra, seeds="0-2", on_chunk=None):
    argv = ["ddpg", TASK, "--seeds", seeds, *QUICK, "--out", str(out), "--name", name, *extra]
    return train_cmd.main(argv, on_chunk=on_chunk)


def files(run_dir):
    return {f: (run_dir / f).read_bytes() for f in (runs.METRICS_FILE, runs.CHECKPOINT_FILE)}


def no_temp_files(run_dir):
    return not [f for f in os.listdir(run_dir) if f.startswith(".") or f.endswith(".tmp")]


class Crash(RuntimeError):
    pass


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """An uninterrupted 20-episode run of seeds 0-2 (two chunks of 10)."""
    out = tmp_path_factory.mktemp("runs")
    assert train(out, "ref") == 0
    return out / "ref"


def test_run_directory_and_numbers(reference, capsys):
    run = runs.Run.open(reference)
    rows = run.read_metrics()
    assert len(rows) == 3 * 20
    assert run.config == make_config("ddpg", TASK, "quick", QUICK[3::2]) and run.seeds == (0, 1, 2)
    assert run.progress()["status"] == "finished" and run.progress()["episodes"] == 20
    for seed in (0, 1, 2):
        mine = [r for r in rows if int(r["seed"]) == seed]
        assert [int(r["episode"]) for r in mine] == list(range(1, 21))
        # PuckTrajectory1 episodes run their full 30 steps; env_steps is the running total
        assert [int(r["env_steps"]) for r in mine] == [30 * e for e in range(1, 21)]
        assert [int(r["episode"]) for r in mine if r["eval_return"]] == [10, 20]
        # learning starts at env step 50: no update in episode 1, finite losses after
        assert float(mine[0]["critic_loss"]) == 0.0
        assert all(np.isfinite(float(r["critic_loss"])) and float(r["critic_loss"]) > 0
                   for r in mine[1:])
        assert all(float(r["return"]) < 0 for r in mine)
    state, done = run.load_checkpoint(runs.make_trainer(run.config))
    assert done == 20 and np.asarray(state.agent.env_steps).tolist() == [600] * 3
    assert sorted(os.listdir(reference / runs.TB_DIR)) == ["seed_0", "seed_1", "seed_2"]
    assert no_temp_files(reference)


def test_same_seed_gives_identical_files(reference, tmp_path, capsys):
    assert train(tmp_path, "again") == 0
    assert files(tmp_path / "again") == files(reference)
    out = capsys.readouterr().out
    assert out.startswith("final evaluation: environment return ")
    assert f"run {tmp_path / 'again'}" in out


def test_resume_after_crash_equals_uninterrupted(reference, tmp_path):
    def crash_after_first_chunk(run, done):
        if done == 10:
            raise Crash

    with pytest.raises(Crash):
        train(tmp_path, "b", on_chunk=crash_after_first_chunk)
    progress = json.loads((tmp_path / "b" / runs.PROGRESS_FILE).read_text())
    assert progress["status"] == "failed" and progress["episodes"] == 10
    assert train_cmd.main(["--resume", str(tmp_path / "b")]) == 0
    assert files(tmp_path / "b") == files(reference)
    assert runs.Run.open(tmp_path / "b").progress()["status"] == "finished"


def test_rows_past_checkpoint_dropped_on_resume(reference, tmp_path, monkeypatch, capsys):
    """A crash after chunk 2's metrics rows but before its checkpoint: resume drops them."""
    save = runs.Run.save_checkpoint

    def save_or_crash(self, state):
        if int(np.asarray(state.episode)[0]) == 20:
            raise Crash
        save(self, state)

    monkeypatch.setattr(runs.Run, "save_checkpoint", save_or_crash)
    with pytest.raises(Crash):
        train(tmp_path, "c")
    assert len(runs.Run.open(tmp_path / "c").read_metrics()) == 60
    monkeypatch.setattr(runs.Run, "save_checkpoint", save)
    assert train_cmd.main(["--resume", str(tmp_path / "c")]) == 0
    assert "dropped 30 metrics rows" in capsys.readouterr().err
    assert files(tmp_path / "c") == files(reference)
    assert no_temp_files(tmp_path / "c")


def test_resume_of_finished_run(reference, tmp_path, capsys):
    """Resuming a finished run trains nothing; --episodes must not cut below what is done."""
    shutil.copytree(reference, tmp_path / "d")
    assert train_cmd.main(["--resume", str(tmp_path / "d")]) == 0
    assert files(tmp_path / "d") == files(reference)
    assert capsys.readouterr().out.startswith("final evaluation: environment return ")
    assert train_cmd.main(["--resume", str(tmp_path / "d"), "--episodes", "15"]) == 2
    assert "--episodes 15 is fewer than the 20 episodes" in capsys.readouterr().err
    assert train_cmd.main(["--resume", str(tmp_path / "d"), "--set", "episodes=5"]) == 2
    assert "drop --set" in capsys.readouterr().err
    assert files(tmp_path / "d") == files(reference)


def test_extending_a_run_whose_last_chunk_was_short(tmp_path):
    """30 episodes in chunks of 20 end on a short chunk (20 + 10); ``--resume --episodes 40``
    runs 10 more to reach the 40-episode config's boundary and equals a 40-episode run."""
    chunks = ["--set", "chunk_episodes=20"]
    assert train(tmp_path, "short", *chunks, "--set", "episodes=30") == 0
    assert train_cmd.main(["--resume", str(tmp_path / "short"), "--episodes", "40"]) == 0
    assert train(tmp_path, "long", *chunks, "--set", "episodes=40") == 0
    assert files(tmp_path / "short") == files(tmp_path / "long")
    assert runs.Run.open(tmp_path / "short").progress()["episodes"] == 40


def test_seed_order_does_not_matter(reference, tmp_path):
    """Same batch size, seeds permuted: every seed's rows are bitwise those of the reference."""
    assert train(tmp_path, "perm", seeds="2,0,1") == 0
    perm, ref = (runs.Run.open(p).read_metrics() for p in (tmp_path / "perm", reference))
    for seed in (0, 1, 2):
        assert [r for r in perm if r["seed"] == str(seed)] == [
            r for r in ref if r["seed"] == str(seed)]


@pytest.mark.xla_optimized  # XLA's old fusion emitters (CI's lowered level) round them apart
def test_seed_of_many_equals_seed_alone(tmp_path):
    """Seeds are independent: seed i of a 0-2 run is, bit for bit, the run of seed i alone (on
    CPU the seeds of a device run one after another, each its own unbatched computation:
    hiddpg.devices.batch_seeds)."""
    assert train(tmp_path, "together") == 0
    all_rows = runs.Run.open(tmp_path / "together").read_metrics()
    for seed in (0, 2):
        assert train(tmp_path, f"s{seed}", seeds=str(seed)) == 0
        alone = runs.Run.open(tmp_path / f"s{seed}").read_metrics()
        together = [r for r in all_rows if int(r["seed"]) == seed]
        assert len(alone) == len(together) == 20
        assert alone == together


@pytest.mark.parametrize("extra,needle", [
    (["--set", "agent.actor_lr=-1"], "actor_lr"),
    (["--set", "agent.nope=1"], "'nope'"),
    (["--set", "agent.batch_size=64", "--set", "agent.buffer_size=32"], "batch_size"),
    (["--seeds", "5-2"], "5-2"),
    (["--seeds", "0,x"], "'x'"),
    (["--set", "env.nope=3"], "nope"),
    (["--preset", "huge"], "huge"),
])
def test_bad_input_exits_2_before_anything(tmp_path, capsys, extra, needle):
    assert train(tmp_path, "bad", *extra) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("hiddpg train: error:")
    assert needle in err
    if "nope" in needle and "agent" in extra[1]:
        assert "allowed" in err and "critic_lr" in err
    assert not (tmp_path / "bad").exists()


@pytest.mark.parametrize("argv,needle", [
    (["ddpg", "NoSuchTask"], "NoSuchTask"),
    (["dqn", TASK], "dqn"),
    (["hi-ddpg", TASK, "--set", "agent.duration_min=50"], "duration_min"),
    ([], "ALGO and TASK"),
    (["--resume", "/nonexistent/run"], "--resume '/nonexistent/run' does not exist"),
])
def test_bad_command_exits_2(tmp_path, capsys, argv, needle):
    assert train_cmd.main([*argv, "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert needle in err and len(err.strip().splitlines()) == 1
    assert os.listdir(tmp_path) == []


def test_existing_run_dir_exits_2(reference, capsys):
    assert train(reference.parent, "ref") == 2
    assert "exists" in capsys.readouterr().err


def test_non_finite_loss_in_first_chunk(tmp_path, capsys):
    assert train(tmp_path, "nan", "--set", "agent.critic_lr=1e30", seeds="0") == 1
    err = capsys.readouterr().err
    ckpt = tmp_path / "nan" / runs.CHECKPOINT_FILE
    assert "non-finite" in err and "loss for seed 0" in err and str(ckpt) in err
    run = runs.Run.open(tmp_path / "nan")
    assert run.progress()["status"] == "failed" and run.progress()["episodes"] == 0
    _, done = run.load_checkpoint(runs.make_trainer(run.config))
    assert done == 0  # the untrained state, written before the first chunk


def test_non_finite_loss_keeps_last_good_checkpoint(reference, tmp_path, monkeypatch, capsys):
    """A poisoned agent: critic loss becomes NaN for seed 1 from episode 13 on."""
    real = runs.make_trainer

    class Poisoned:
        def __init__(self, trainer):
            self._t = trainer

        def __getattr__(self, name):
            return getattr(self._t, name)

        def run_chunk_seeds(self, state, n):
            state, train_m, eval_m = self._t.run_chunk_seeds(state, n)
            loss = np.array(train_m["critic_loss"])
            loss[1, np.asarray(train_m["episode"])[1] >= 13] = np.nan
            return state, dict(train_m, critic_loss=loss), eval_m

    monkeypatch.setattr(train_cmd, "make_trainer", lambda cfg: Poisoned(real(cfg)))
    assert train(tmp_path, "poison") == 1
    err = capsys.readouterr().err
    ckpt = tmp_path / "poison" / runs.CHECKPOINT_FILE
    assert "non-finite critic_loss for seed 1 at episode 13" in err
    assert f"Last good checkpoint (episode 10): {ckpt}" in err
    run = runs.Run.open(tmp_path / "poison")
    assert run.progress()["status"] == "failed" and run.progress()["episodes"] == 10
    _, done = run.load_checkpoint(real(run.config))
    assert done == 10 and no_temp_files(tmp_path / "poison")
    # the failed chunk's rows stay for diagnosis; a resume would drop them
    assert len(run.read_metrics()) == 60


def test_eval_replays_the_final_policy(reference, tmp_path, capsys):
    """PuckTrajectory1 is deterministic: the noise-free replay of the checkpoint scores exactly
    the final evaluation recorded during training; --gif draws the whole episode."""
    from PIL import Image

    from hiddpg.commands import eval as eval_cmd

    final = runs.Run.open(reference).final_eval()
    gif = tmp_path / "seed1.gif"
    assert eval_cmd.main([str(reference), "--seed", "1", "--gif", str(gif)]) == 0
    lines = capsys.readouterr().out.splitlines()
    seed_line = next(line.split() for line in lines if line.split()[:1] == ["1"])
    assert float(seed_line[1]) == pytest.approx(final[1], abs=1e-3)
    assert seed_line[3:] == ["0", "30"]  # switches, length
    with Image.open(gif) as im:
        assert im.n_frames == 30 and im.size[0] == 400
    assert eval_cmd.main([str(reference), "--seed", "7"]) == 2
    assert "--seed 7 is not in the run" in capsys.readouterr().err
    assert eval_cmd.main([str(tmp_path)]) == 2


def test_sigterm_marks_the_run_interrupted_and_it_resumes(tmp_path):
    """``kill`` (SIGTERM) of a real ``hiddpg train`` process: exit 143, the run says
    ``interrupted`` by SIGTERM at its last checkpoint and how to resume, and resuming finishes
    it (signals at many moments: tests/test_faults.py)."""
    import subprocess
    import sys
    import time

    run_dir = tmp_path / "killed"
    argv = [sys.executable, "-m", "hiddpg.cli", "train", "ddpg", TASK, "--seeds", "0", *QUICK,
            "--set", "episodes=100000", "--out", str(tmp_path), "--name", "killed"]
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 240
    while time.monotonic() < deadline and proc.poll() is None:
        progress = run_dir / runs.PROGRESS_FILE
        if progress.is_file() and json.loads(progress.read_text())["episodes"] >= 10:
            break
        time.sleep(0.2)
    proc.terminate()
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 143, err
    assert f"stopped by SIGTERM; continue with: hiddpg train --resume {run_dir}" in err
    progress = runs.Run.open(run_dir).progress()
    assert progress["status"] == "interrupted" and progress["episodes"] >= 10
    assert progress["signal"] == "SIGTERM"
    assert progress["episodes"] % 10 == 0  # a chunk boundary: the last checkpoint
    done = progress["episodes"]
    assert train_cmd.main(["--resume", str(run_dir), "--episodes", str(done + 10)]) == 0
    final = runs.Run.open(run_dir).progress()
    assert final["status"] == "finished" and final["episodes"] == done + 10

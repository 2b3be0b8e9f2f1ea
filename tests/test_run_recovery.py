"""Every file of a run is checked before it is trusted: a damaged or missing file is refused
with one message naming it (exit 1, nothing changed) or, where the run can be recovered, it is
recovered, said so, and the resumed run ends byte-identical to an uninterrupted one."""

from __future__ import annotations

import shutil

import pytest

from hiddpg import run_check, runs
from hiddpg.commands import train as train_cmd

QUICK = ["--preset", "quick", "--set", "episodes=30", "--set", "eval_every=10",
         "--set", "chunk_episodes=10", "--set", "agent.hidden=[16,16]",
         "--set", "agent.learning_starts=50"]
TASK = "PuckTrajectory1"


def train(out, name, *extra):
    argv = ["ddpg", TASK, "--seeds", "0-1", *QUICK, "--out", str(out), "--name", name, *extra]
    return train_cmd.main(argv)


def resume(run_dir, *extra):
    return train_cmd.main(["--resume", str(run_dir), *extra])


def snapshot(run_dir):
    """Every regular file of the run directory (bytes), TensorBoard and the lock aside."""
    return {p.name: p.read_bytes() for p in run_dir.iterdir()
            if p.is_file() and p.name != "writer.lock"}


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """An uninterrupted 30-episode run (three chunks of 10) and the same run stopped at 20."""
    out = tmp_path_factory.mktemp("runs")
    assert train(out, "ref") == 0
    assert train(out, "at20", "--episodes", "20") == 0
    return out


@pytest.fixture
def stopped(reference, tmp_path):
    """A copy of the run stopped at episode 20 (budget 20: resume with --episodes 30)."""
    dst = tmp_path / "run"
    shutil.copytree(reference / "at20", dst)
    return dst


def finishes_like_reference(reference, run_dir):
    assert resume(run_dir, "--episodes", "30") == 0
    ref = reference / "ref"
    for name in (runs.METRICS_FILE, runs.CHECKPOINT_FILE):
        assert (run_dir / name).read_bytes() == (ref / name).read_bytes(), name


def test_the_previous_checkpoint_is_kept(reference):
    run = runs.Run.open(reference / "ref")
    assert run.checkpoint_episodes() == 30
    prev = run_check.read_raw(run.previous_checkpoint_path)
    assert run_check.raw_episodes(prev) == 20


def test_missing_metrics_is_refused_and_nothing_changes(reference, stopped, capsys):
    (stopped / runs.METRICS_FILE).unlink()
    before = snapshot(stopped)
    assert resume(stopped, "--episodes", "30") == 1
    err = capsys.readouterr().err
    assert "metrics.csv" in err and "is missing" in err and "20 episodes" in err
    assert "history" in err and "backup" in err and "Traceback" not in err
    assert snapshot(stopped) == before


def test_metrics_shorter_than_the_checkpoint_recovers_from_the_previous_one(reference, stopped,
                                                                          capsys):
    """metrics.csv ends at episode 10 while the checkpoint is at 20: the previous checkpoint
    (episode 10) matches the history, so the run continues from it, says so, and still ends
    byte-identical to the uninterrupted run."""
    path = stopped / runs.METRICS_FILE
    lines = path.read_text().splitlines(keepends=True)
    path.write_text("".join(lines[:1 + 2 * 10]))
    finishes_like_reference(reference, stopped)
    err = capsys.readouterr().err
    assert "metrics.csv ends at episode 10" in err and "previous checkpoint" in err
    assert list(stopped.glob("checkpoint.msgpack.damaged*"))  # set aside, not deleted


@pytest.mark.parametrize("damage", ["garbage", "truncated", "empty"])
def test_damaged_checkpoint_recovers_from_the_previous_one(reference, stopped, capsys, damage):
    ckpt = stopped / runs.CHECKPOINT_FILE
    data = ckpt.read_bytes()
    ckpt.write_bytes({"garbage": b"\x00not a checkpoint" * 50, "truncated": data[:len(data) // 2],
                      "empty": b""}[damage])
    finishes_like_reference(reference, stopped)
    err = capsys.readouterr().err
    assert "checkpoint.msgpack.damaged" in err and "previous checkpoint at episode 10" in err
    assert (stopped / "checkpoint.msgpack.damaged").read_bytes() != data


def test_both_checkpoints_damaged_is_refused(reference, stopped, capsys):
    for name in (runs.CHECKPOINT_FILE, runs.PREVIOUS_CHECKPOINT_FILE):
        (stopped / name).write_bytes(b"\x93garbage")
    before = snapshot(stopped)
    assert resume(stopped, "--episodes", "30") == 1
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0, err  # one line
    assert "checkpoint" in err and "not a readable checkpoint" in err and "new run" in err
    assert snapshot(stopped) == before


def test_checkpoint_of_another_config_names_the_mismatch(reference, tmp_path, capsys):
    """A checkpoint whose arrays do not fit the run's config (here: a config.json edited to
    wider networks) is named with the first array that differs."""
    other = tmp_path / "other"
    assert train(tmp_path, "other", "--episodes", "10", "--set", "agent.hidden=[8,8]") == 0
    for name in (runs.CHECKPOINT_FILE, runs.PREVIOUS_CHECKPOINT_FILE):
        shutil.copy(reference / "at20" / runs.CHECKPOINT_FILE, other / name)
    capsys.readouterr()
    assert resume(other, "--episodes", "30") == 1
    err = capsys.readouterr().err
    assert "float32[2, 16]" in err and "float32[2, 8]" in err and "this run's config" in err


def test_missing_current_checkpoint_uses_the_previous_one(reference, stopped, capsys):
    """Killed between keeping the previous checkpoint and writing the new one."""
    (stopped / runs.CHECKPOINT_FILE).unlink()
    finishes_like_reference(reference, stopped)
    assert "is missing (a write was cut short)" in capsys.readouterr().err


@pytest.mark.parametrize("damage", [b"", b"{not json", b'{"episodes": 3}'])
def test_damaged_progress_is_rewritten(reference, stopped, capsys, damage):
    (stopped / runs.PROGRESS_FILE).write_bytes(damage)
    finishes_like_reference(reference, stopped)
    assert "progress.json" in capsys.readouterr().err
    assert runs.Run.open(stopped).progress()["status"] == "finished"


@pytest.mark.parametrize("damage", [b"", b"{not json", b'{"seeds": [0, 1]}',
                                    b'{"config": {"algo": "ddpg", "nope": 1}, "seeds": [0]}'])
def test_damaged_config_is_refused(reference, stopped, capsys, damage):
    (stopped / runs.CONFIG_FILE).write_bytes(damage)
    before = snapshot(stopped)
    assert resume(stopped) == 1
    err = capsys.readouterr().err
    assert "config.json" in err and "restore it" in err and "Traceback" not in err
    assert snapshot(stopped) == before


def test_duplicated_or_foreign_metrics_rows_are_refused(reference, stopped, capsys):
    """The rows a second writer would have added (episodes again) are caught by resume and by
    every reader of the metrics."""
    path = stopped / runs.METRICS_FILE
    lines = path.read_text().splitlines(keepends=True)
    path.write_text("".join(lines + lines[-4:]))
    before = snapshot(stopped)
    assert resume(stopped, "--episodes", "30") == 1
    err = capsys.readouterr().err
    assert f"line {len(lines) + 1}: seed 0 repeats episode 19 after episode 20" in err
    assert snapshot(stopped) == before
    with pytest.raises(runs.RunFileError, match="repeats episode"):
        runs.Run.open(stopped).read_metrics()


def test_torn_last_line_and_leftover_temporaries_are_cleaned(reference, stopped):
    """A crash mid-append leaves half a row; a crash mid-write leaves a temporary file."""
    with open(stopped / runs.METRICS_FILE, "a") as f:
        f.write("0,21,63")
    (stopped / ".checkpoint.msgpack.abc.tmp").write_bytes(b"partial")
    finishes_like_reference(reference, stopped)
    assert not list(stopped.glob(".*.tmp"))


def test_finished_run_says_so(reference, tmp_path, capsys):
    dst = tmp_path / "done"
    shutil.copytree(reference / "ref", dst)
    before = snapshot(dst)
    assert resume(dst) == 0
    captured = capsys.readouterr()
    assert "is finished (30 episodes); nothing to do" in captured.err
    assert "--episodes N (N > 30)" in captured.err
    assert "resuming" not in captured.err
    assert snapshot(dst) == before

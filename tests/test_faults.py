"""Real ``hiddpg train`` processes killed, signalled and run twice at once.

* SIGKILL at random moments, resumed each time: the finished run's metrics.csv and checkpoint
  are byte-identical to an uninterrupted run's.
* SIGTERM / SIGINT at many moments, from compilation to the last chunk: the process ends at
  once with 143 / 130, never a crash, and progress.json names the signal.
* Two writers: a second process that opens a run being trained is refused, naming the
  holder; the lock of a killed holder is taken over; the metrics stay intact.
"""

from __future__ import annotations

import json
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from hiddpg import runs
from hiddpg.commands import train as train_cmd

pytestmark = pytest.mark.slow

EPISODES = 150
QUICK = ["--preset", "quick", "--set", f"episodes={EPISODES}", "--set", "eval_every=10",
         "--set", "chunk_episodes=10", "--set", "agent.hidden=[16,16]",
         "--set", "agent.learning_starts=50"]
NEW = ["ddpg", "PuckTrajectory1", "--seeds", "0-1", *QUICK]


def start(*argv: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "hiddpg.cli", "train", *argv],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def new_run(out: Path, name: str) -> subprocess.Popen:
    return start(*NEW, "--out", str(out), "--name", name)


def handles_signals(proc: subprocess.Popen, timeout: float = 60.0) -> None:
    """Wait until the process has installed its SIGTERM handler (/proc/PID/status SigCgt)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and proc.poll() is None:
        try:
            status = Path(f"/proc/{proc.pid}/status").read_text()
        except FileNotFoundError:
            break
        caught = int(next(line for line in status.splitlines()
                          if line.startswith("SigCgt:")).split()[1], 16)
        if caught >> (signal.SIGTERM - 1) & 1:
            return
        time.sleep(0.02)
    raise AssertionError(f"no SIGTERM handler installed (exit {proc.poll()})")


def lock_holder(run_dir: Path) -> int | None:
    try:
        return json.loads((run_dir / "writer.lock").read_text())["pid"]
    except (FileNotFoundError, ValueError, KeyError):
        return None


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("ref")
    assert train_cmd.main([*NEW, "--out", str(out), "--name", "ref"]) == 0
    return out / "ref"


def same_as_reference(run_dir: Path, reference: Path) -> None:
    for name in (runs.METRICS_FILE, runs.CHECKPOINT_FILE):
        assert (run_dir / name).read_bytes() == (reference / name).read_bytes(), name
    assert runs.Run.open(run_dir).progress()["status"] == "finished"


@pytest.mark.heavy
def test_sigkill_at_random_moments_then_resume_is_bit_identical(reference, tmp_path):
    rng = random.Random(21)
    run_dir = tmp_path / "killed"
    kills = 0
    while kills < 5:
        proc = start("--resume", str(run_dir)) if (run_dir / "config.json").is_file() \
            else new_run(tmp_path, "killed")
        time.sleep(rng.uniform(1.0, 7.0))
        if proc.poll() is not None:  # finished before the kill
            break
        proc.kill()
        proc.communicate(timeout=60)
        kills += 1
    if runs.Run.open(run_dir).progress()["status"] != "finished":
        proc = start("--resume", str(run_dir))
        _, err = proc.communicate(timeout=600)
        assert proc.returncode == 0, err
    assert kills >= 3
    same_as_reference(run_dir, reference)
    assert not list(run_dir.glob(".*.tmp"))


@pytest.mark.parametrize("sig", [signal.SIGTERM,
                                 pytest.param(signal.SIGINT, marks=pytest.mark.heavy)])
def test_signals_at_many_moments_stop_cleanly(reference, tmp_path, sig):
    """From argument parsing and compilation to training chunks: exit 128 + signal within
    seconds, no crash, the run (if made) marked interrupted with the signal's name, or left
    finished as it was when training ended before the signal; the last interrupted one is
    then resumed to the end and matches the uninterrupted run."""
    interrupted = []
    # (from, delay): the first two moments count from the start (parsing, imports); the others
    # from the run directory's config.json, so a slow, loaded machine still signals the run
    # during compilation and training rather than before it exists.
    moments = [("start", 0.0), ("start", 0.4), ("run", 0.0), ("run", 0.5), ("run", 1.5),
               ("run", 3.0)]
    for i, (since, delay) in enumerate(moments):
        name = f"s{i}"
        proc = new_run(tmp_path, name)
        handles_signals(proc)
        deadline = time.monotonic() + 60
        while (since == "run" and not (tmp_path / name / "config.json").is_file()
               and proc.poll() is None and time.monotonic() < deadline):
            time.sleep(0.05)
        time.sleep(delay)
        proc.send_signal(sig)
        t0 = time.monotonic()
        _, err = proc.communicate(timeout=60)
        assert time.monotonic() - t0 < 15, f"took {time.monotonic() - t0:.1f} s to stop"
        assert proc.returncode == 128 + sig, (delay, proc.returncode, err)
        assert "Traceback" not in err and "Segmentation" not in err, err
        run_dir = tmp_path / name
        if (run_dir / "config.json").is_file():
            progress = runs.Run.open(run_dir).progress()
            assert lock_holder(run_dir) is None  # released
            if progress["status"] == "finished":  # training ended before the signal came:
                same_as_reference(run_dir, reference)  # a finished run is never rewritten
                assert "--resume" not in err
                continue
            assert progress["status"] == "interrupted", (delay, progress)
            assert progress["signal"] == signal.Signals(sig).name
            assert f"stopped by {signal.Signals(sig).name}" in err
            assert f"hiddpg train --resume {run_dir}" in err
            interrupted.append(run_dir)
    assert len(interrupted) >= 3, interrupted  # the moments up to training's chunks
    assert train_cmd.main(["--resume", str(interrupted[-1])]) == 0
    same_as_reference(interrupted[-1], reference)


@pytest.mark.heavy  # the lock itself, and the CLI's refusal: tests/test_writer_lock.py
def test_second_writer_is_refused_and_a_dead_writers_lock_is_taken_over(reference, tmp_path):
    run_dir = tmp_path / "twice"
    first = new_run(tmp_path, "twice")
    deadline = time.monotonic() + 60
    while lock_holder(run_dir) != first.pid and time.monotonic() < deadline:
        time.sleep(0.05)
    assert lock_holder(run_dir) == first.pid
    # frozen while it holds the lock, so that it cannot finish (and release the lock) however
    # long the second process takes to start on a loaded machine
    os.kill(first.pid, signal.SIGSTOP)
    second = start("--resume", str(run_dir))
    _, err = second.communicate(timeout=120)
    assert second.returncode == 1, err
    assert f"is being trained by pid {first.pid} on host" in err and "since" in err
    first.kill()  # the lock file still names it: stale
    first.communicate(timeout=60)
    assert lock_holder(run_dir) == first.pid
    third = start("--resume", str(run_dir))
    _, err = third.communicate(timeout=600)
    assert third.returncode == 0, err
    assert f"took over the writer lock left by pid {first.pid}" in err
    same_as_reference(run_dir, reference)
    rows = runs.Run.open(run_dir).read_metrics()
    assert len(rows) == 2 * EPISODES


@pytest.mark.heavy  # the lock itself, and the CLI's refusal: tests/test_writer_lock.py
def test_two_resumes_at_once_one_is_refused(reference, tmp_path):
    """The reported case: two ``--resume`` of one stopped run started together. Exactly one
    trains; the other is refused; the metrics hold each episode once."""
    run_dir = tmp_path / "pair"
    assert train_cmd.main([*NEW, "--out", str(tmp_path), "--name", "pair",
                           "--episodes", "50"]) == 0
    procs = [start("--resume", str(run_dir), "--episodes", str(EPISODES)) for _ in range(2)]
    results = [(p.wait(timeout=600), p.stderr.read()) for p in procs]
    codes = sorted(code for code, _ in results)
    assert codes == [0, 1], results
    refused = next(err for code, err in results if code == 1)
    assert "is being trained by pid" in refused
    same_as_reference(run_dir, reference)

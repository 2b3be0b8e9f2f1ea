"""The writer lock of a run directory (:class:`hiddpg.run_files.WriterLock`): one writer at a
time, the holder named to whoever is refused, a dead holder's lock taken over, and the
refusal ``hiddpg train --resume`` prints. The same with real training processes racing for
one run: tests/test_faults.py (heavy)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from hiddpg.commands import train as train_cmd
from hiddpg.presets import make_config
from hiddpg.run_files import LOCK_FILE, RunLockedError, WriterLock
from hiddpg.runner import prepare_new

HOLDER = """
import sys, time
from hiddpg.run_files import WriterLock
lock = WriterLock(sys.argv[1])
lock.acquire()
print("held", flush=True)
time.sleep(600)
"""


def holder_pid(directory: Path) -> int:
    return json.loads((directory / LOCK_FILE).read_text())["pid"]


def test_a_second_writer_is_refused_naming_the_holder_until_it_releases(tmp_path):
    first = WriterLock(tmp_path)
    first.acquire()
    assert holder_pid(tmp_path) == os.getpid()
    second = WriterLock(tmp_path)
    with pytest.raises(RunLockedError, match=rf"is being trained by pid {os.getpid()} on host "
                                             r"\S+ since \S+ \("):
        second.acquire()
    assert not second.held
    first.release()
    assert (tmp_path / LOCK_FILE).read_text() == ""  # released: nobody is named
    second.acquire()
    assert second.held and second.took_over is None
    second.release()


def test_a_dead_processs_lock_is_taken_over_naming_it(tmp_path):
    child = subprocess.Popen([sys.executable, "-c", HOLDER, str(tmp_path)],
                             stdout=subprocess.PIPE, text=True)
    try:
        assert child.stdout.readline().strip() == "held"
        with pytest.raises(RunLockedError, match=rf"pid {child.pid} on host"):
            WriterLock(tmp_path).acquire()  # alive: refused
    finally:
        child.kill()
        child.wait(timeout=60)
    assert holder_pid(tmp_path) == child.pid  # the killed holder's name stays in the file
    lock = WriterLock(tmp_path)
    lock.acquire()
    assert lock.took_over is not None and lock.took_over.startswith(f"pid {child.pid} on host")
    assert holder_pid(tmp_path) == os.getpid()
    lock.release()


def test_resume_of_a_run_another_process_writes_exits_1_and_changes_nothing(tmp_path, capsys):
    run = prepare_new(make_config("ddpg", "PuckTrajectory1", "quick", []), [0, 1],
                      tmp_path / "run")
    run.release()
    before = {p.name: p.read_bytes() for p in run.path.iterdir() if p.is_file()}
    other = WriterLock(run.path)
    other.acquire()
    try:
        assert train_cmd.main(["--resume", str(run.path)]) == 1
    finally:
        err = capsys.readouterr().err
        other.release()
    assert f"is being trained by pid {os.getpid()} on host" in err
    after = {p.name: p.read_bytes() for p in run.path.iterdir() if p.is_file()}
    assert {k: v for k, v in after.items() if k != LOCK_FILE} == \
        {k: v for k, v in before.items() if k != LOCK_FILE}

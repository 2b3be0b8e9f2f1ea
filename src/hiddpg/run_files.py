"""The file-level guarantees of a run directory: atomic writes, one writer, clear errors.

* :func:`atomic_write` writes a temporary file in the same directory, fsyncs it and renames
  it over the target, holding :data:`hiddpg.stopping.WRITE_LOCK`: a crash or a signal leaves
  the previous complete file, never a torn one.
* :class:`WriterLock` makes a process the only writer of a run directory: an exclusive
  ``flock`` on ``RUN/writer.lock``, whose text names the holder (pid, host, command, since
  when). The kernel releases the lock when its process ends, however it ends, so the lock
  of a killed process is taken over by the next writer, which says whose it was.
* :class:`RunFileError` is a damaged or missing run file: its message names the file, what
  is wrong and what the user can do.
"""

from __future__ import annotations

import fcntl
import json
import os
import socket
import sys
import tempfile
import time
from pathlib import Path

from hiddpg.stopping import writing

LOCK_FILE = "writer.lock"
FILE_MODE = 0o644


class RunFileError(ValueError):
    """A run file that cannot be trusted; the message says which, why and what to do."""

    def __init__(self, path: Path | str, problem: str, remedy: str) -> None:
        super().__init__(f"{path}: {problem}; {remedy}")
        self.path, self.problem, self.remedy = Path(path), problem, remedy


class RunLockedError(RuntimeError):
    """Another live process is writing the run directory."""


def atomic_write(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` via a temporary file in the same directory, fsync, replace."""
    with writing():
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
        try:
            with os.fdopen(fd, "wb") as f:
                os.fchmod(f.fileno(), FILE_MODE)
                f.write(data)
                f.flush()
                os.fsync(f.fileno())
            os.replace(tmp, path)
        except BaseException:
            if os.path.exists(tmp):
                os.unlink(tmp)
            raise


def remove_stale_temporaries(directory: Path) -> list[str]:
    """Delete the temporary files of writes that never finished (``.NAME.*.tmp``); returns
    their names. Only the directory's writer may call this."""
    gone = []
    for tmp in sorted(directory.glob(".*.tmp")):
        tmp.unlink(missing_ok=True)
        gone.append(tmp.name)
    return gone


def _holder_text() -> str:
    return json.dumps({"pid": os.getpid(), "host": socket.gethostname(),
                       "since": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
                       "command": " ".join(sys.argv[:8])[:200]}) + "\n"


def describe_holder(text: str) -> str:
    """``pid 123 on host h since <local time> (command)`` from a lock file's text (best effort)."""
    try:
        h = json.loads(text)
        return f"pid {h['pid']} on host {h['host']} since {h['since']} ({h['command']})"
    except (ValueError, KeyError, TypeError):
        return "an unknown process"


class WriterLock:
    """The exclusive right to write one run directory (``RUN/writer.lock``)."""

    def __init__(self, directory: Path) -> None:
        self.path = Path(directory) / LOCK_FILE
        self._fd: int | None = None
        self.took_over: str | None = None
        """The holder a stale lock named, if this lock was taken over from a dead process."""

    @property
    def held(self) -> bool:
        return self._fd is not None

    def acquire(self) -> None:
        """Take the lock or raise :class:`RunLockedError` naming the live holder."""
        if self._fd is not None:
            return
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT, FILE_MODE)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = describe_holder(os.pread(fd, 4096, 0).decode(errors="replace"))
            os.close(fd)
            raise RunLockedError(
                f"{self.path.parent} is being trained by {holder}; wait for it to finish or "
                "stop it, then try again") from None
        previous = os.pread(fd, 4096, 0).decode(errors="replace").strip()
        self.took_over = describe_holder(previous) if previous else None
        with writing():
            os.ftruncate(fd, 0)
            os.pwrite(fd, _holder_text().encode(), 0)
            os.fsync(fd)
        self._fd = fd

    def release(self) -> None:
        """Give the lock up and clear the holder's name (the file stays: deleting a locked
        file would let two processes lock two different files)."""
        if self._fd is None:
            return
        fd, self._fd = self._fd, None
        with writing():
            os.ftruncate(fd, 0)
            fcntl.flock(fd, fcntl.LOCK_UN)
            os.close(fd)

    def __del__(self) -> None:  # the kernel would release it anyway; keep the file clean
        try:
            self.release()
        except OSError:
            pass

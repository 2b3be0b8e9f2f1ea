"""Stop a command promptly and cleanly on SIGTERM or SIGINT, at any moment of a run.

Under the ``hiddpg`` command (:func:`install`), a signal does not raise in the main thread:
Python's C-level handler writes the signal number to a pipe, and a watcher thread reads it
at once, even while the main thread waits in XLA (compiling, or running a chunk that takes
minutes). The watcher then

1. takes :data:`WRITE_LOCK`, which the main thread holds around every write to a run
   directory (:func:`writing`), so no file is left half-written;
2. calls the stop actions registered with :func:`on_stop`, newest first: a training run
   records ``interrupted`` with the signal's name in progress.json, says how to resume and
   releases its writer lock; a sweep stops its worker processes;
3. flushes stdout and stderr and ends the process with ``os._exit(128 + signum)``: 143 for
   SIGTERM, 130 for SIGINT (Ctrl-C).

``os._exit`` skips the interpreter's shutdown, in which XLA's threads could still be running
(raising ``KeyboardInterrupt`` into a running computation and exiting normally can end in a
segmentation fault). The chunk in flight is discarded: the run continues from its last
checkpoint, as it would after ``kill -9``.

Library use (a notebook, a test calling a command's ``main``) installs nothing: there Ctrl-C
raises ``KeyboardInterrupt`` as usual and :func:`hiddpg.runner.train_run` marks the run
interrupted.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager

#: held by the main thread around every write to a run directory, and by the watcher
#: before it stops the process; re-entrant, since one write may nest another.
WRITE_LOCK = threading.RLock()
#: the signals :func:`install` handles, with their exit codes (128 + signal number).
SIGNALS = (signal.SIGTERM, signal.SIGINT)

_actions: list[Callable[[str], None]] = []
_installed = False


@contextmanager
def writing() -> Iterator[None]:
    """Hold :data:`WRITE_LOCK` for one write (or a sequence that must not be cut)."""
    with WRITE_LOCK:
        yield


@contextmanager
def on_stop(action: Callable[[str], None]) -> Iterator[None]:
    """Register ``action(signal_name)`` to run if a signal stops the process while the
    ``with`` block runs; it runs holding :data:`WRITE_LOCK`, before the process exits."""
    with WRITE_LOCK:
        _actions.append(action)
    try:
        yield
    finally:
        with WRITE_LOCK:
            _actions.remove(action)


def installed() -> bool:
    """Whether :func:`install` has run in this process."""
    return _installed


def install() -> None:
    """Route SIGTERM and SIGINT to the watcher thread (main thread only; call once, before
    work starts). Idempotent."""
    global _installed
    if _installed:
        return
    read_fd, write_fd = os.pipe()
    os.set_blocking(write_fd, False)
    for sig in SIGNALS:  # a Python handler must exist for the C handler to write the pipe
        signal.signal(sig, _ignore)
    signal.set_wakeup_fd(write_fd, warn_on_full_buffer=False)
    threading.Thread(target=_watch, args=(read_fd,), name="hiddpg-stop", daemon=True).start()
    _installed = True


def _ignore(signum: int, frame: object) -> None:
    """The main thread's handler: nothing; the watcher thread acts."""
    del signum, frame


def _watch(read_fd: int) -> None:
    while True:
        data = os.read(read_fd, 1)
        if not data:
            return
        if data[0] in {int(s) for s in SIGNALS}:
            stop(data[0])


def stop(signum: int) -> None:
    """Run the stop actions for ``signum`` and end the process with ``128 + signum``."""
    name = signal.Signals(signum).name
    WRITE_LOCK.acquire()  # never released: the process ends holding it
    for action in reversed(list(_actions)):
        try:
            action(name)
        except BaseException as err:  # noqa: BLE001 - the process must still end
            print(f"hiddpg: while stopping on {name}: {err!r}", file=sys.stderr)
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):
            pass
    os._exit(128 + signum)

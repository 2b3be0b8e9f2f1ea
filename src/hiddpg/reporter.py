"""What a training run tells a person while it trains: :class:`Reporter` and the console one.

:func:`hiddpg.runner.train_run` calls a reporter when it resumes a run, before the first
chunk, after every chunk and at the end; the base class says nothing, :class:`ConsoleReporter`
draws a rich progress bar on a terminal and writes one plain line per chunk otherwise.
"""

from __future__ import annotations

import sys
from pathlib import Path


class Reporter:
    """Hears how a run trains; this base class says nothing (library use, tests)."""

    def resumed(self, path: Path, episodes: int, dropped: int) -> None:
        """A run is continued at ``episodes``; ``dropped`` metrics rows past its checkpoint
        were removed."""

    def start(self, title: str, total: int, done: int) -> None:
        """Training of ``title`` starts at ``done`` of ``total`` episodes."""

    def update(self, done: int, *, train_return: float, eval_return: float,
               steps_per_s: float) -> None:
        """A chunk ended at ``done`` episodes: its recent mean training return, the last mean
        evaluation return and its environment steps per second."""

    def close(self) -> None:
        """Training stopped (finished, failed or interrupted); may be called twice."""


class ConsoleReporter(Reporter):
    """A rich progress bar on a terminal; one plain line per chunk otherwise (logs, CI)."""

    def __init__(self) -> None:
        self.title, self.total = "", 0
        self.bar = None

    def resumed(self, path: Path, episodes: int, dropped: int) -> None:
        print(f"resuming {path} at episode {episodes}"
              + (f" (dropped {dropped} metrics rows past the checkpoint)" if dropped else ""),
              file=sys.stderr)

    def start(self, title: str, total: int, done: int) -> None:
        from rich.console import Console

        self.title, self.total = title, total
        console = Console(stderr=True)
        if not console.is_terminal:
            return
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            TextColumn,
            TimeElapsedColumn,
        )

        self.bar = Progress(
            TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
            TextColumn("return {task.fields[ret]}  eval {task.fields[eval]}  "
                       "{task.fields[sps]} env steps/s"),
            TimeElapsedColumn(), console=console)
        self.task = self.bar.add_task(title, total=total, completed=done,
                                      ret="-", eval="-", sps="-")
        self.bar.start()

    def update(self, done: int, *, train_return: float, eval_return: float,
               steps_per_s: float) -> None:
        ret, evl, sps = f"{train_return:.2f}", f"{eval_return:.2f}", f"{steps_per_s:,.0f}"
        if self.bar is not None:
            self.bar.update(self.task, completed=done, ret=ret, eval=evl, sps=sps)
        else:
            print(f"{self.title}  episode {done}/{self.total}  return {ret}  eval {evl}  "
                  f"{sps} env steps/s", file=sys.stderr, flush=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.stop()
            self.bar = None

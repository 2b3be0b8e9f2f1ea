"""The sweep's progress display: episodes done over all its runs (:class:`SweepProgress`)."""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from hiddpg import sweep
from hiddpg.runs import PROGRESS_FILE

#: without a terminal, a progress line at most this often
LOG_EVERY_S = 10.0
#: the progress files of all runs are read at most this often
READ_EVERY_S = 2.0


def reason(code: int | str) -> str:
    """A run's failure as words: the error's text, or its exit code."""
    return code if isinstance(code, str) else f"exit code {code}"


class SweepProgress:
    """One progress bar for the whole sweep: episodes done over all its runs, read from each
    run's progress.json (so it works for runs trained anywhere that writes to OUT)."""

    def __init__(self, out: Path, runs: list[sweep.SweepRun]) -> None:
        from rich.console import Console

        self.out, self.runs = out, runs
        self.total = sum(run.config.episodes for run in runs)
        self.finished = 0
        self.console = Console(stderr=True)
        self.bar, self.last_log, self.last_read, self.done = None, time.monotonic(), 0.0, 0
        if self.console.is_terminal and runs:
            from rich.progress import (
                BarColumn,
                MofNCompleteColumn,
                Progress,
                TextColumn,
                TimeElapsedColumn,
            )

            self.bar = Progress(TextColumn("[bold]sweep"), BarColumn(), MofNCompleteColumn(),
                                TextColumn("episodes  {task.fields[runs]}"),
                                TimeElapsedColumn(), console=self.console)
            self.task = self.bar.add_task("sweep", total=self.total, runs="")
            self.bar.start()

    def episodes_done(self) -> int:
        done = 0
        for run in self.runs:
            try:
                done += json.loads((self.out / run.name / PROGRESS_FILE).read_text())["episodes"]
            except (FileNotFoundError, json.JSONDecodeError, KeyError):
                pass
        return done

    def poll(self, force: bool = False) -> None:
        if force or time.monotonic() - self.last_read >= READ_EVERY_S:
            self.done, self.last_read = self.episodes_done(), time.monotonic()
        done, runs = self.done, f"{self.finished}/{len(self.runs)} runs done"
        if self.bar is not None:
            self.bar.update(self.task, completed=done, runs=runs)
        elif time.monotonic() - self.last_log >= LOG_EVERY_S:
            self.last_log = time.monotonic()
            print(f"sweep: {done}/{self.total} episodes, {runs}", file=sys.stderr, flush=True)

    def run_done(self, run: sweep.SweepRun, code: int | str) -> None:
        self.finished += 1
        status = "finished" if code == 0 else f"FAILED ({reason(code)})"
        self.console.print(f"{run.name}: {status}", highlight=False)
        self.poll(force=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.stop()
            self.bar = None

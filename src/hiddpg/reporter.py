"""What a training run tells a person while it trains: :class:`Reporter` and the console one.

:func:`hiddpg.runner.train_run` calls a reporter when it resumes a run, before the first
chunk, after every chunk and at the end; the command may first hand it the run's plan
(:func:`hiddpg.plan.describe`). The base class says nothing; :class:`ConsoleReporter` draws a
rich progress bar on a terminal and writes one plain line per chunk otherwise.

The time left is estimated by :class:`Pace` from the chunks after the first: the first one
includes XLA's compilation, which can take longer than several chunks of training.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, TextIO

from hiddpg.plan import eta_text, plural

#: What the time left reads before a second chunk has ended.
ETA_PENDING = "ETA after the next chunk"


class Reporter:
    """Hears how a run trains; this base class says nothing (library use, tests)."""

    def plan(self, text: str) -> None:
        """What the run will do (:func:`hiddpg.plan.describe`), before it starts."""

    def note(self, text: str) -> None:
        """Something opening the run recovered or changed (``Run.notes``)."""

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


class Pace:
    """Episodes per second and the time left, from the times of the chunks' ends.

    ``start`` marks the loop's start; each ``mark`` a chunk's end. The rate is measured from
    the end of the first chunk (compilation included) to the end of the last one, so it needs
    two chunks; until then :meth:`left` is ``None``.
    """

    def __init__(self, total: int, done: int, now: float) -> None:
        self.total, self.begin = total, now
        self.marks: list[tuple[float, int]] = []
        self.done = done

    def mark(self, now: float, done: int) -> None:
        self.marks.append((now, done))
        self.done = done

    @property
    def first_chunk(self) -> float | None:
        """Seconds the first chunk took, compilation included."""
        return self.marks[0][0] - self.begin if self.marks else None

    def rate(self) -> float | None:
        """Episodes per second after the first chunk; ``None`` before a second chunk."""
        if len(self.marks) < 2:
            return None
        (t0, d0), (t1, d1) = self.marks[0], self.marks[-1]
        return (d1 - d0) / (t1 - t0) if t1 > t0 else None

    def left(self) -> float | None:
        """Seconds to the last episode at :meth:`rate`; 0 when done, ``None`` if unknown."""
        if self.done >= self.total:
            return 0.0
        rate = self.rate()
        return None if not rate else (self.total - self.done) / rate


class ConsoleReporter(Reporter):
    """A rich progress bar on a terminal; one plain line per chunk otherwise (logs, CI).

    Both show the episodes done of the total, the recent training return, the last
    evaluation return, the environment steps per second and the time left. In plain mode one
    more line says, when the time left is first known, how long the rest will take.

    Args:
        clock: seconds, monotonic (:func:`time.monotonic`; tests pass a fake one).
        stream: where to write (default: ``sys.stderr`` at the time of writing).
        terminal: draw the bar (True) or write lines (False); None: a bar if ``stream`` is
            a terminal.
    """

    def __init__(self, *, clock: Callable[[], float] = time.monotonic,
                 stream: TextIO | None = None, terminal: bool | None = None) -> None:
        self.clock, self.stream, self.terminal = clock, stream, terminal
        self.title, self.total = "", 0
        self.pace: Pace | None = None
        self.bar: Any = None
        self.told_eta = False
        self.stats = "return -  eval -  - env steps/s"

    def _out(self) -> TextIO:
        return self.stream if self.stream is not None else sys.stderr

    def _say(self, text: str) -> None:
        if self.bar is not None:
            self.bar.console.print(text, markup=False, highlight=False)
        else:
            print(text, file=self._out(), flush=True)

    def plan(self, text: str) -> None:
        self._say(text)

    def note(self, text: str) -> None:
        self._say(f"note: {text}")

    def resumed(self, path: Path, episodes: int, dropped: int) -> None:
        self._say(f"resuming {path} at episode {episodes}"
                  + (f" (dropped {dropped} metrics rows past the checkpoint)" if dropped else ""))

    def start(self, title: str, total: int, done: int) -> None:
        from rich.console import Console

        self.title, self.total = title, total
        self.pace, self.told_eta = Pace(total, done, self.clock()), False
        self.stats = "return -  eval -  - env steps/s"
        console = Console(file=self._out(), force_terminal=self.terminal)
        if not (console.is_terminal if self.terminal is None else self.terminal):
            return
        self.bar = _progress_bar(self, console, title, total, done)
        self.bar.start()

    def time_left(self) -> str:
        """``ETA about 3 min``, :data:`ETA_PENDING`, or ``took about 5 min`` at the end."""
        pace = self.pace
        if pace is None or not pace.marks:
            return ETA_PENDING
        if pace.done >= pace.total:
            return f"took {eta_text(pace.marks[-1][0] - pace.begin)}"
        left = pace.left()
        if left is None:
            return ETA_PENDING
        since = self.clock() - pace.marks[-1][0] if self.bar is not None else 0.0
        return f"ETA {eta_text(max(left - since, 0.0))}"

    def update(self, done: int, *, train_return: float, eval_return: float,
               steps_per_s: float) -> None:
        if self.pace is None:  # update without start: time from here
            self.pace = Pace(self.total, 0, self.clock())
        self.pace.mark(self.clock(), done)
        ret, evl, sps = f"{train_return:.2f}", f"{eval_return:.2f}", f"{steps_per_s:,.0f}"
        self.stats = f"return {ret}  eval {evl}  {sps} env steps/s"
        if self.bar is not None:
            self.bar.update(self.bar.task_ids[0], completed=done)
            return
        print(f"{self.title}  episode {done}/{self.total}  {self.stats}  {self.time_left()}",
              file=self._out(), flush=True)
        left, rate = self.pace.left(), self.pace.rate()
        if not self.told_eta and left and rate:
            self.told_eta = True
            print(f"{self.title}: the remaining {plural(self.total - done, 'episode')} will take "
                  f"{eta_text(left)} at {rate:.3g} episodes/s (the first chunk, compilation "
                  f"included, took {self.pace.first_chunk:.1f} s)",
                  file=self._out(), flush=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.stop()
            self.bar = None


def _progress_bar(reporter: ConsoleReporter, console: Any, title: str, total: int,
                  done: int) -> Any:
    """Two lines that fit 80 columns: the title, the bar, episodes done and the time left
    (counting down between chunks); below them ``reporter.stats``."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, ProgressColumn, TextColumn
    from rich.table import Column
    from rich.text import Text

    class TimeLeft(ProgressColumn):
        def render(self, task: Any) -> Text:
            return Text(reporter.time_left(), style="progress.remaining")

    class Bar(Progress):
        def get_renderables(self):
            yield self.make_tasks_table(self.tasks)
            yield Text(reporter.stats)

    bar = Bar(TextColumn("[bold]{task.description}",
                         table_column=Column(overflow="ellipsis", no_wrap=True)),
              BarColumn(bar_width=20), MofNCompleteColumn(), TimeLeft(), console=console)
    bar.add_task(title, total=total, completed=done)
    return bar

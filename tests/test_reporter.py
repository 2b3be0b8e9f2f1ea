"""What the console says while a run trains (hiddpg.reporter), driven by a fake clock: the time
left is estimated from the chunks after the first (which includes compilation), said once
when first known, and counts down on a terminal."""

from __future__ import annotations

import io
import re

import pytest

from hiddpg.reporter import ETA_PENDING, ConsoleReporter, Pace, Reporter

TITLE = "hi-ddpg PuckTrajectory1"


class Clock:
    """A clock that moves only when told."""

    def __init__(self) -> None:
        self.now = 1000.0

    def __call__(self) -> float:
        return self.now


def train(reporter: ConsoleReporter, clock: Clock, chunks: list[float], total: int = 1000,
          done: int = 0, size: int = 100) -> None:
    """Chunks of ``size`` episodes taking ``chunks`` seconds each."""
    reporter.start(TITLE, total, done)
    for seconds in chunks:
        clock.now += seconds
        done += size
        reporter.update(done, train_return=-12.345, eval_return=-6.5, steps_per_s=4321.0)
    reporter.close()


def plain(chunks: list[float], **kw) -> list[str]:
    clock, out = Clock(), io.StringIO()
    reporter = ConsoleReporter(clock=clock, stream=out, terminal=False)
    reporter.plan("the plan")
    train(reporter, clock, chunks, **kw)
    return out.getvalue().splitlines()


def test_plain_lines_estimate_from_the_second_chunk_on():
    # the first chunk compiles for 10 min, then each chunk of 100 episodes takes 1 min
    lines = plain([600.0] + [60.0] * 9)
    head = f"{TITLE}  episode {{}}/1000  return -12.35  eval -6.50  4,321 env steps/s  "
    assert lines[0] == "the plan"
    assert lines[1] == head.format(100) + ETA_PENDING
    # 800 episodes left at 100 per 60 s: 8 min (with the first chunk counted: 44 min)
    assert lines[2] == head.format(200) + "ETA about 8 min"
    assert lines[3] == (f"{TITLE}: the remaining 800 episodes will take about 8 min at 1.67 "
                        "episodes/s (the first chunk, compilation included, took 600.0 s)")
    etas = [re.search(r"ETA about (\d+) min$", line) for line in lines[4:-2]]
    assert [int(m.group(1)) for m in etas] == [7, 6, 5, 4, 3, 2]
    assert lines[-2] == head.format(900) + "ETA about 1 min"
    assert lines[-1] == head.format(1000) + "took about 19 min"
    assert len(lines) == 12  # the plan, 10 chunks, the committed time once


def test_eta_averages_the_chunks_after_the_first():
    # after the first: 30 s then 90 s for 100 episodes each, 1 min per 100 on average
    lines = plain([5.0, 30.0, 90.0], total=600)
    assert lines[2].endswith("ETA about 2 min")  # 400 left at 100 per 30 s
    assert lines[4].endswith("ETA about 3 min")  # 300 left at 200 per 120 s


def test_a_resumed_run_counts_from_its_start():
    lines = plain([300.0, 20.0], total=1000, done=600)
    assert lines[1].endswith("episode 700/1000  return -12.35  eval -6.50  4,321 env steps/s  "
                             + ETA_PENDING)
    assert lines[2].endswith("episode 800/1000  return -12.35  eval -6.50  4,321 env steps/s  "
                             "ETA under a minute")  # 200 left at 5 per s
    assert "the remaining 200 episodes will take under a minute at 5 episodes/s" in lines[3]


def test_a_single_chunk_says_how_long_it_took():
    assert plain([75.0], total=100) == [
        "the plan", f"{TITLE}  episode 100/100  return -12.35  eval -6.50  4,321 env steps/s  "
        "took about 1 min"]


def test_resumed_message(capsys):
    reporter = ConsoleReporter(terminal=False)
    reporter.resumed("runs/x", 300, 0)
    reporter.resumed("runs/x", 300, 4)
    assert capsys.readouterr().err.splitlines() == [
        "resuming runs/x at episode 300",
        "resuming runs/x at episode 300 (dropped 4 metrics rows past the checkpoint)"]


def test_pace():
    pace = Pace(total=500, done=100, now=10.0)
    assert pace.rate() is None and pace.left() is None and pace.first_chunk is None
    pace.mark(70.0, 200)
    assert pace.first_chunk == 60.0 and pace.rate() is None and pace.left() is None
    pace.mark(80.0, 300)
    assert pace.rate() == pytest.approx(10.0) and pace.left() == pytest.approx(20.0)
    pace.mark(100.0, 500)
    assert pace.left() == 0.0


def test_terminal_bar_counts_down_between_chunks():
    clock, out = Clock(), io.StringIO()
    reporter = ConsoleReporter(clock=clock, stream=out, terminal=True)
    reporter.start(TITLE, 1000, 0)
    assert reporter.time_left() == ETA_PENDING
    clock.now += 600.0
    reporter.update(100, train_return=-1.0, eval_return=-2.0, steps_per_s=10.0)
    assert reporter.time_left() == ETA_PENDING
    clock.now += 60.0
    reporter.update(200, train_return=-1.0, eval_return=-2.0, steps_per_s=10.0)
    assert reporter.time_left() == "ETA about 8 min"
    clock.now += 180.0  # three minutes into the next chunk
    assert reporter.time_left() == "ETA about 5 min"
    clock.now += 120.0
    reporter.update(1000, train_return=-1.0, eval_return=-2.0, steps_per_s=10.0)
    reporter.close()
    shown = re.sub(r"\x1b\[[0-9;?]*[A-Za-z]", "", out.getvalue())
    assert "1000/1000" in shown
    assert shown.endswith("took about 16 min\nreturn -1.00  eval -2.00  10 env steps/s\n")
    assert "the remaining" not in shown  # the bar shows the time left itself


def test_the_base_reporter_is_silent(capsys):
    reporter = Reporter()
    reporter.plan("the plan")
    reporter.start(TITLE, 10, 0)
    reporter.update(10, train_return=0.0, eval_return=0.0, steps_per_s=1.0)
    reporter.close()
    assert capsys.readouterr() == ("", "")

"""The run loop as a library (:mod:`hiddpg.runner`), no command line: a run trained to its end,
one interrupted after its first chunk and resumed (byte-identical files), a non-finite loss,
an exception, and the validation of seeds, run directories and resume budgets."""

from __future__ import annotations

import json

import numpy as np
import pytest

from hiddpg import runner, runs, summary
from hiddpg.machine import describe
from hiddpg.presets import make_config
from hiddpg.reporter import Reporter
from hiddpg.runner import (
    FAILED,
    FINISHED,
    INTERRUPTED,
    RunResult,
    open_for_resume,
    parse_seeds,
    prepare_new,
    train_run,
)
from hiddpg.runs import make_trainer

CONFIG = make_config("ddpg", "PuckTrajectory1", "quick",
                     ["episodes=20", "eval_every=10", "chunk_episodes=10",
                      "agent.hidden=[16,16]", "agent.learning_starts=50"])
SEEDS = [0, 1]


class Recorder(Reporter):
    """Remembers what the loop reported."""

    def __init__(self) -> None:
        self.calls: list[tuple] = []

    def resumed(self, path, episodes, dropped):
        self.calls.append(("resumed", path, episodes, dropped))

    def start(self, title, total, done):
        self.calls.append(("start", title, total, done))

    def update(self, done, *, train_return, eval_return, steps_per_s):
        assert np.isfinite(train_return) and np.isfinite(eval_return) and steps_per_s > 0
        self.calls.append(("update", done))


def files(path):
    return {f: (path / f).read_bytes() for f in (runs.METRICS_FILE, runs.CHECKPOINT_FILE)}


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """An uninterrupted 20-episode run of seeds 0-1 (two chunks of 10) and its result."""
    path = tmp_path_factory.mktemp("runner") / "ref"
    run = prepare_new(CONFIG, SEEDS, path)
    assert run.progress() == {"episodes": 0, "total_episodes": 20, "wall_time": 0.0,
                              "status": "running",
                              "machines": [{"machine": describe(), "episodes": [0, 0],
                                            "wall_time": 0.0}]}
    recorder = Recorder()
    result = train_run(run, make_trainer(CONFIG), reporter=recorder)
    return path, result, recorder


def test_a_run_trained_to_its_end(reference):
    path, result, recorder = reference
    assert result.status == FINISHED and result.episodes == 20 and result.error is None
    assert result.wall_time > 0
    assert recorder.calls == [("start", "ddpg PuckTrajectory1", 20, 0),
                              ("update", 10), ("update", 20)]
    run = runs.Run.open(path)
    progress = run.progress()
    assert progress["status"] == FINISHED and progress["episodes"] == 20
    assert progress["wall_time"] == round(result.wall_time, 3)
    rows = run.read_metrics()
    assert [(int(r["episode"]), int(r["seed"])) for r in rows] == [
        (e, s) for e in range(1, 21) for s in SEEDS]
    assert [int(r["env_steps"]) for r in rows if r["seed"] == "1"] == [
        30 * e for e in range(1, 21)]
    assert [int(r["episode"]) for r in rows if r["eval_return"] and r["seed"] == "0"] == [10, 20]
    _, done = run.load_checkpoint(make_trainer(CONFIG))
    assert done == 20 == run.checkpoint_episodes()
    finals = [float(r["eval_env_return"]) for r in rows if r["episode"] == "20"]
    line = summary.result_line(run, 12.34)
    mean, std = summary.number(np.mean(finals)), summary.number(np.std(finals, ddof=1))
    assert line.startswith(f"final evaluation: environment return {mean} ± {std} "
                           "(mean ± std over 2 seeds)")
    assert line.endswith(f" | wall 12.3 s | run {path}")


def test_interrupted_after_first_chunk_then_resumed_equals_uninterrupted(reference, tmp_path):
    ref_path, ref_result, _ = reference
    seen = []

    def stop_after_first_chunk(run, episodes):
        seen.append(episodes)
        raise KeyboardInterrupt

    path = tmp_path / "stopped"
    result = train_run(prepare_new(CONFIG, SEEDS, path), make_trainer(CONFIG),
                       on_chunk=stop_after_first_chunk)
    assert seen == [10]
    assert result.status == INTERRUPTED and result.episodes == 10 and result.error is None
    progress = runs.Run.open(path).progress()
    assert progress["status"] == INTERRUPTED and progress["episodes"] == 10
    assert progress["wall_time"] == result.wall_time > 0
    assert len(runs.Run.open(path).read_metrics()) == 2 * 10

    run, trainer, done = open_for_resume(path)
    assert done == 10 and trainer.config == CONFIG and run.seeds == (0, 1)
    recorder = Recorder()
    resumed = train_run(run, trainer, reporter=recorder)
    assert resumed.status == FINISHED and resumed.episodes == 20
    assert resumed.wall_time > result.wall_time
    assert recorder.calls == [("resumed", path, 10, 0),
                              ("start", "ddpg PuckTrajectory1", 20, 10), ("update", 20)]
    assert files(path) == files(ref_path)
    assert runs.Run.open(path).progress()["status"] == FINISHED


def test_a_finished_run_resumes_to_nothing(reference):
    path, _, _ = reference
    before = files(path)
    run, trainer, done = open_for_resume(path)
    assert done == 20
    result = train_run(run, trainer)
    assert result.status == FINISHED and result.episodes == 20
    assert files(path) == before


def test_non_finite_loss_keeps_the_last_good_checkpoint(reference, tmp_path):
    """Critic loss NaN for seed 1 from episode 13: failed at the first chunk's checkpoint."""
    real = make_trainer(CONFIG)

    class Poisoned:
        config = CONFIG

        def __getattr__(self, name):
            return getattr(real, name)

        def run_chunk_seeds(self, state, n):
            state, train_m, eval_m = real.run_chunk_seeds(state, n)
            loss = np.array(train_m["critic_loss"])
            loss[1, np.asarray(train_m["episode"])[1] >= 13] = np.nan
            return state, dict(train_m, critic_loss=loss), eval_m

    path = tmp_path / "poison"
    result = train_run(prepare_new(CONFIG, SEEDS, path), Poisoned())
    ckpt = path / runs.CHECKPOINT_FILE
    assert result.status == FAILED and result.episodes == 10
    assert result.error == ("non-finite critic_loss for seed 1 at episode 13; training stopped. "
                            f"Last good checkpoint (episode 10): {ckpt}")
    progress = runs.Run.open(path).progress()
    assert (progress["status"], progress["episodes"], progress["error"]) == (
        FAILED, 10, result.error)
    assert runs.Run.open(path).checkpoint_episodes() == 10
    assert len(runs.Run.open(path).read_metrics()) == 2 * 20  # the failed chunk's rows stay


def test_an_exception_marks_the_run_failed_and_propagates(reference, tmp_path):
    def crash(run, episodes):
        raise RuntimeError("disk full")

    path = tmp_path / "crash"
    with pytest.raises(RuntimeError, match="disk full"):
        train_run(prepare_new(CONFIG, SEEDS, path), make_trainer(CONFIG), on_chunk=crash)
    progress = json.loads((path / runs.PROGRESS_FILE).read_text())
    assert progress["status"] == FAILED and progress["episodes"] == 10
    assert progress["error"] == "RuntimeError('disk full')"


@pytest.mark.parametrize("text,seeds", [
    ("0-14", list(range(15))), ("0,3,5", [0, 3, 5]), ("7", [7]), ("4-5, 0", [4, 5, 0]),
])
def test_parse_seeds(text, seeds):
    assert parse_seeds(text) == seeds


@pytest.mark.parametrize("text,message", [
    ("0,x", "seeds '0,x': 'x' is not a seed, a range like 0-14 or a list like 0,3,5"),
    ("5-2", "seeds '5-2': range '5-2' is empty (start 5 > end 2)"),
    ("1,0-2", "seeds '1,0-2': seed(s) [1] given twice"),
    ("", "seeds '': '' is not a seed, a range like 0-14 or a list like 0,3,5"),
])
def test_bad_seeds_are_value_errors_naming_the_text(text, message):
    with pytest.raises(ValueError) as info:
        parse_seeds(text)
    assert type(info.value) is ValueError and str(info.value) == message


def test_prepare_new_validates_before_writing(reference, tmp_path):
    path, _, _ = reference
    with pytest.raises(FileExistsError, match=f"run directory {path} exists"):
        prepare_new(CONFIG, SEEDS, path)
    with pytest.raises(ValueError, match=r"seeds \[0, 1, 0\]: seed\(s\) \[0\] given twice"):
        prepare_new(CONFIG, [0, 1, 0], tmp_path / "dup")
    with pytest.raises(ValueError, match=r"seeds \[\]: give at least one seed"):
        prepare_new(CONFIG, [], tmp_path / "none")
    assert not (tmp_path / "dup").exists() and not (tmp_path / "none").exists()


def test_open_for_resume_validates(reference, tmp_path):
    path, _, _ = reference
    with pytest.raises(ValueError, match=f"episodes 15 is fewer than the 20 episodes {path}"):
        open_for_resume(path, episodes=15)
    with pytest.raises(FileNotFoundError, match="not a run directory"):
        open_for_resume(tmp_path)
    run, trainer, done = open_for_resume(path, episodes=40)
    assert done == 20 and trainer.config.episodes == 40 and run.config.episodes == 20
    assert runs.Run.open(path).config == CONFIG  # nothing written until train_run


def test_result_is_a_frozen_value():
    result = RunResult(FINISHED, 20, 1.5)
    with pytest.raises(AttributeError):
        result.status = FAILED  # type: ignore[misc]
    assert result == RunResult("finished", 20, 1.5, None)
    assert runner.INTERRUPTED == "interrupted"


def test_a_stop_after_the_finish_leaves_the_run_finished(reference, tmp_path):
    """A signal or Ctrl-C that lands after progress.json says finished (before the lock is
    given up) keeps the run finished; an extended run's earlier finish does not count."""
    import shutil

    path = tmp_path / "late"
    shutil.copytree(reference[0], path)
    before = (path / runs.PROGRESS_FILE).read_bytes()
    run = runs.Run.open(path)
    run.acquire()
    runner.mark_stopped(run, "SIGTERM")
    assert (path / runs.PROGRESS_FILE).read_bytes() == before
    assert not run.lock.held

    def interrupt_at_the_end(run, episodes):
        if episodes == 20:
            run.write_progress(episodes, 1.0, FINISHED)
            raise KeyboardInterrupt

    late = tmp_path / "late-ctrl-c"
    result = train_run(prepare_new(CONFIG, SEEDS, late), make_trainer(CONFIG),
                       on_chunk=interrupt_at_the_end)
    assert result.status == FINISHED and result.episodes == 20
    assert runs.Run.open(late).progress()["status"] == FINISHED

    extended = tmp_path / "extended"
    shutil.copytree(reference[0], extended)
    run, trainer, done = open_for_resume(extended, episodes=30)
    run.update_config(trainer.config)
    runner.mark_stopped(run, "SIGTERM")
    progress = runs.Run.open(extended).progress()
    assert (progress["status"], progress["episodes"], progress["total_episodes"]) == (
        INTERRUPTED, 20, 30)

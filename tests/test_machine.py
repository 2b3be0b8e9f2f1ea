"""Which machine trained which episodes (:mod:`hiddpg.machine`): the spans progress.json keeps,
a run resumed on another machine, the artifact and its parts carrying them, the report's
table."""

from __future__ import annotations

import json

import pytest

from hiddpg import machine, runs
from hiddpg.experiments.artifacts import export_run, read_meta
from hiddpg.experiments.report import machines_table
from hiddpg.machine import extend_spans, machine_text
from hiddpg.presets import make_config
from hiddpg.runner import FINISHED, open_for_resume, prepare_new, train_run
from hiddpg.runs import make_trainer

A = {"cpu": "Xeon", "isa": "AVX-512", "cores": 2, "device": "cpu"}
B = {"cpu": "EPYC", "isa": "AVX2", "cores": 2, "device": "cpu"}
CONFIG = make_config("ddpg", "PuckTrajectory1", "quick",
                     ["episodes=20", "eval_every=10", "chunk_episodes=10",
                      "agent.hidden=[16,16]", "agent.learning_starts=50"])


def progress(episodes, wall, spans):
    return {"episodes": episodes, "wall_time": wall, "status": "running", "machines": spans}


def test_a_new_run_starts_one_empty_span_that_the_same_machine_extends():
    first = extend_spans(None, 0, 0.0, A)
    assert first == [{"machine": A, "episodes": [0, 0], "wall_time": 0.0}]
    spans = extend_spans(progress(0, 0.0, first), 250, 100.0, A)
    spans = extend_spans(progress(250, 100.0, spans), 500, 230.5, A)
    assert spans == [{"machine": A, "episodes": [0, 500], "wall_time": 230.5}]


def test_another_machine_starts_a_span_with_its_own_seconds():
    spans = [{"machine": A, "episodes": [0, 500], "wall_time": 230.5}]
    spans = extend_spans(progress(500, 230.5, spans), 750, 330.5, B)
    assert spans == [{"machine": A, "episodes": [0, 500], "wall_time": 230.5},
                     {"machine": B, "episodes": [500, 750], "wall_time": 100.0}]
    # back on the first machine: a third span, not a merge with the first
    spans = extend_spans(progress(750, 330.5, spans), 1000, 340.5, A)
    assert [s["machine"] for s in spans] == [A, B, A]
    assert [s["episodes"] for s in spans] == [[0, 500], [500, 750], [750, 1000]]
    assert spans[-1]["wall_time"] == 10.0


def test_episodes_trained_before_spans_were_recorded_are_a_span_of_no_machine():
    old = {"episodes": 2160, "wall_time": 6077.056, "status": "running"}
    spans = extend_spans(old, 2400, 6320.0, B)
    assert spans == [{"machine": None, "episodes": [0, 2160], "wall_time": 6077.056},
                     {"machine": B, "episodes": [2160, 2400], "wall_time": 242.944}]
    assert machine_text(None) == "not recorded"
    assert machine_text(B) == "EPYC (AVX2, 2 cores, cpu)"


def test_a_resume_from_an_older_checkpoint_cuts_the_spans_back():
    spans = [{"machine": A, "episodes": [0, 500], "wall_time": 200.0},
             {"machine": B, "episodes": [500, 750], "wall_time": 100.0}]
    cut = extend_spans(progress(750, 300.0, spans), 500, 200.0, A)
    assert cut == [{"machine": A, "episodes": [0, 500], "wall_time": 200.0}]
    cut = extend_spans(progress(750, 300.0, spans), 250, 100.0, B)
    assert cut == [{"machine": A, "episodes": [0, 250], "wall_time": 200.0},
                   {"machine": B, "episodes": [250, 250], "wall_time": 0.0}]
    # malformed entries are ignored, never a traceback
    assert extend_spans(progress(0, 0.0, "junk"), 10, 1.0, A) == [
        {"machine": A, "episodes": [0, 10], "wall_time": 1.0}]


def test_describe_names_this_machine():
    here = machine.describe()
    assert set(here) == {"cpu", "isa", "cores", "device"}
    assert isinstance(here["cpu"], str) and here["cpu"]
    assert here["cores"] >= 1 and here["device"] == "cpu"
    assert here["isa"] in {label for label, _ in machine.ISA_FLAGS} | {None}
    assert json.loads(json.dumps(here)) == here  # survives progress.json unchanged


@pytest.fixture
def resumed_elsewhere(tmp_path, monkeypatch):
    """A 20-episode run: its first chunk on machine A, stopped, resumed on machine B."""
    path = tmp_path / "run"

    def stop(run, episodes):
        raise KeyboardInterrupt

    monkeypatch.setattr(runs, "describe", lambda: A)
    train_run(prepare_new(CONFIG, [0, 1], path), make_trainer(CONFIG), on_chunk=stop)
    monkeypatch.setattr(runs, "describe", lambda: B)
    run, trainer, _ = open_for_resume(path)
    assert train_run(run, trainer).status == FINISHED
    return path


def test_a_run_resumed_on_another_machine_records_both(resumed_elsewhere, tmp_path):
    progress_json = runs.Run.open(resumed_elsewhere).progress()
    spans = progress_json["machines"]
    assert [s["machine"] for s in spans] == [A, B]
    assert [s["episodes"] for s in spans] == [[0, 10], [10, 20]]
    assert all(s["wall_time"] > 0 for s in spans)
    assert sum(s["wall_time"] for s in spans) == pytest.approx(progress_json["wall_time"],
                                                               abs=2e-3)
    out = tmp_path / "out"
    dest = export_run(resumed_elsewhere, out / "artifacts" / "ddpg-PuckTrajectory1")
    assert read_meta(dest)["machines"] == spans
    lines = machines_table(out)
    assert lines[2:] == [
        f"| ddpg-PuckTrajectory1 | 0-1 | 1-10 | Xeon (AVX-512, 2 cores, cpu) | "
        f"{spans[0]['wall_time']} |",
        f"| ddpg-PuckTrajectory1 | 0-1 | 11-20 | EPYC (AVX2, 2 cores, cpu) | "
        f"{spans[1]['wall_time']} |"]


def test_an_artifact_without_machines_reads_not_recorded(tmp_path):
    folder = tmp_path / "artifacts" / "hi-ddpg-PuckObstacle"
    folder.mkdir(parents=True)
    meta = {"seeds": [0, 1], "episodes": 3000, "wall_time": 12.5, "status": "finished",
            "parts": [{"part": "seeds-0", "seeds": [0], "episodes": 3000, "wall_time": 5.0},
                      {"part": "seeds-1", "seeds": [1], "episodes": 3000, "wall_time": 7.5,
                       "machines": [{"machine": B, "episodes": [0, 3000],
                                     "wall_time": 7.5}]}]}
    (folder / "meta.json").write_text(json.dumps(meta))
    assert machines_table(tmp_path)[2:] == [
        "| hi-ddpg-PuckObstacle | 0 | 1-3000 | not recorded | 5.0 |",
        "| hi-ddpg-PuckObstacle | 1 | 1-3000 | EPYC (AVX2, 2 cores, cpu) | 7.5 |"]

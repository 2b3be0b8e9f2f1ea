"""``hiddpg sweep`` over a Gymnasium task (tests/host/line_env.py): the spec's ``goal`` and
``skills`` declare it as ``hiddpg train --goal/--skills`` do, a declaration is part of the run's
name, holds for its own runs only, is recorded in every run directory and the manifest, and a
declaration that cannot work is named before anything runs."""

from __future__ import annotations

import json
import tomllib

import pytest

from hiddpg import runs, sweep
from hiddpg.commands import sweep as sweep_cmd
from hiddpg.envs import GoalSpace
from hiddpg.host import GYM_TASKS
from hiddpg.host.declare import declarations_scope

TASK = "line_env:LineWorld-v0"
SPEC = f"""
algos = ["ddpg", "hi-ddpg"]
tasks = "{TASK}"
seeds = "0-1"
presets = "quick"
goal = ["0:-2:2"]
[set]
episodes = 4
eval_every = 2
chunk_episodes = 2
"agent.learning_starts" = 5
"""
HI_SETS = {"agent.high.hidden": [8, 8], "agent.low.hidden": [8, 8], "agent.pretrain_episodes": 0}


def spec(**extra):
    """The spec's table with ``extra`` keys replaced."""
    return {**tomllib.loads(SPEC), **extra}


def grouped():
    """ddpg and hi-ddpg, each with its own small networks."""
    return spec(algos="ddpg", group=[
        {"set": {"agent.hidden": [8, 8]}},
        {"algos": "hi-ddpg", "set": HI_SETS}])


def test_a_declaration_is_passed_on_named_and_forgotten():
    before = dict(GYM_TASKS)
    ddpg, hi = sweep.expand(grouped())
    assert GYM_TASKS == before  # validating the runs left no declaration behind
    assert hi.task == ddpg.task == "gym:" + TASK
    assert hi.name.startswith("hi-ddpg-gym_line_env_LineWorld-v0-quick-")
    argv = hi.train_argv(sweep.Path("out"))
    assert argv[argv.index("--goal") + 1] == "0:-2:2" and "--skills" not in argv
    # another goal is another run directory; the same goal the same one
    (other,) = sweep.expand({**grouped(), "group": [{"algos": "hi-ddpg", "set": HI_SETS,
                                                      "goal": ["0:-1:1"]}]})
    assert other.goal == ("0:-1:1",) and other.name != hi.name
    assert [r.name for r in sweep.expand(grouped())] == [ddpg.name, hi.name]


@pytest.mark.parametrize("extra, message", [
    ({"goal": ["2:0:1"]}, "run 1 (hi-ddpg line_env:LineWorld-v0 preset quick)"),
    ({"goal": ["0:1:-1"]}, "--goal '0:1:-1': LOW 1 must be below HIGH -1"),
    ({"goal": "0:0:1", "tasks": "PuckTrajectory1"}, "--goal declares a Gymnasium task's goal"),
    ({"goal": [1]}, "goal = [1] must be a string or a non-empty list of strings"),
    ({"skills": 3}, "skills = 3 must be a string MODULE:FUNCTION"),
])
def test_a_declaration_that_cannot_work_is_named_before_anything_runs(extra, message, tmp_path,
                                                                      capsys):
    path = tmp_path / "sweep.toml"
    path.write_text(SPEC.replace('algos = ["ddpg", "hi-ddpg"]', 'algos = "hi-ddpg"'))
    table = spec(algos="hi-ddpg", **extra)
    with pytest.raises(sweep.SweepError) as err:
        sweep.expand(table)
    assert message in str(err.value)
    if "goal" in extra and isinstance(extra["goal"], list) and isinstance(extra["goal"][0], str):
        argv = [str(path), "--out", str(tmp_path / "out"), "--goal", extra["goal"][0]]
        if "tasks" in extra:
            argv += ["--tasks", extra["tasks"]]
        assert sweep_cmd.main(argv) == 2
        assert message in capsys.readouterr().err
        assert not (tmp_path / "out").exists()


@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    """The two runs trained by ``hiddpg sweep`` (local backend, in this process)."""
    tmp = tmp_path_factory.mktemp("gym-sweep")
    path = tmp / "sweep.toml"
    path.write_text(SPEC + '\n[[group]]\nalgos = "ddpg"\nset = { "agent.hidden" = [8, 8] }\n'
                    '\n[[group]]\nalgos = "hi-ddpg"\n'
                    'set = { "agent.high.hidden" = [8, 8], "agent.low.hidden" = [8, 8], '
                    '"agent.pretrain_episodes" = 0 }\n')
    out = tmp / "out"
    assert sweep_cmd.main([str(path), "--out", str(out)]) == 0
    return path, out, sweep.expand(sweep.load_spec(path))


def test_swept_runs_are_train_runs_with_their_declaration(swept, capsys):
    path, out, planned = swept
    manifest = json.loads((out / sweep.MANIFEST_FILE).read_text())["runs"]
    for run in planned:
        meta = json.loads((out / run.name / runs.CONFIG_FILE).read_text())
        assert meta["gym_task"]["goal"] == {"0": [-2.0, 2.0]}
        assert meta["sources"]["goal"] == {"from": "--goal / register_gym_task",
                                           "entries": {"0": [-2.0, 2.0]}}
        assert sweep.is_finished(out / run.name, 4)
        with declarations_scope():  # opening a run declares its task again
            assert len(runs.Run.open(out / run.name).read_metrics()) == 2 * 4
        assert manifest[run.name]["goal"] == ["0:-2:2"] and "skills" not in manifest[run.name]
    # a second sweep finds them finished and trains nothing, and forgets their declaration
    capsys.readouterr()
    before = dict(GYM_TASKS)
    assert sweep_cmd.main([str(path), "--out", str(out)]) == 0
    assert "2 complete (skipped)" in capsys.readouterr().err and GYM_TASKS == before


def test_a_ray_worker_declares_the_task_and_records_its_sources(swept, tmp_path):
    """``sweep.open_run`` (what a Ray task calls, in a process that never saw the spec)."""
    _, _, planned = swept
    hi = planned[1]
    with declarations_scope():
        assert "line_env:LineWorld-v0" not in GYM_TASKS
        ready = sweep.open_run(hi, tmp_path)
        assert ready is not None and ready.done == 0
        assert GYM_TASKS["line_env:LineWorld-v0"].goal == GoalSpace((0,), (-2.0,), (2.0,))
    meta = json.loads((tmp_path / hi.name / runs.CONFIG_FILE).read_text())
    assert meta["sources"]["goal"]["from"] == "--goal / register_gym_task"

"""A Gymnasium environment from the command line (:mod:`hiddpg.host.declare`): task ids, the
``--goal`` declaration, one-line errors with exit code 2, the presets' generic values, and a
DDPG run of ``line_env:LineWorld-v0`` (tests/host/line_env.py, a ``module:Env-v0`` id)
evaluated and drawn with the environment's own frames, or refused in one line when the
environment cannot draw them. Training, resuming and the goal through the command line:
test_host_mujoco.py."""

from __future__ import annotations

import json
import re
import shutil

import numpy as np
import pytest
from PIL import Image

from hiddpg import cli
from hiddpg.commands import train as train_cmd
from hiddpg.configs import ActorChoice
from hiddpg.envs import GoalSpace
from hiddpg.host import GYM_TASKS, gym_task, make_host_env
from hiddpg.host.declare import (
    declarations_scope,
    declare,
    directory_name,
    parse_goal,
    resolve_task,
)
from hiddpg.host.gif import open_renderer, reset_seed
from hiddpg.presets import make_config
from hiddpg.runner import prepare_new
from hiddpg.train import eval_keys, make_trainer

TASK = "line_env:LineWorld-v0"


def test_goal_entries_and_task_ids():
    assert parse_goal(["9:-1e-1:2", "8:-0.3:0.3"]) == {9: (-0.1, 2.0), 8: (-0.3, 0.3)}
    assert parse_goal([]) is None
    assert resolve_task("Pendulum-v1") == resolve_task("gym:Pendulum-v1") == "gym:Pendulum-v1"
    assert resolve_task(TASK) == "gym:" + TASK  # module:Env-v0, resolved through Gymnasium
    for ours in ("PuckTrajectory1", "hiddpg/PuckTrajectory1-v0", "user_env.slider:Slider"):
        assert resolve_task(ours) == ours  # our tasks stay on the JAX engine
    assert directory_name("gym:" + TASK) == "line_env_LineWorld-v0"
    assert directory_name("gym:hiddpg/PuckTrajectory1-v0") == "hiddpg_PuckTrajectory1-v0"


def test_a_declaration_lasts_as_long_as_its_scope():
    with declarations_scope():
        assert declare(TASK, ["1:-1:1"]) == "gym:" + TASK
        assert gym_task("gym:" + TASK).goal == GoalSpace((1,), (-1.0,), (1.0,))
        assert gym_task("gym:" + TASK).declaration()["goal"] == {"1": [-1.0, 1.0]}
        env = make_host_env("gym:" + TASK)
        assert (env.obs_dim, env.action_dim, env.horizon, env.dt) == (2, 1, 10, 1.0)
    assert TASK not in GYM_TASKS and gym_task("gym:" + TASK).goal is None


def test_a_gym_task_gets_the_presets_generic_values():
    for algo in ("ddpg", "hi-ddpg", "h-ddpg"):
        for preset in ("quick", "paper", "paper+"):
            reacher = make_config(algo, "gym:Reacher-v5", preset)
            assert reacher.agent == make_config(algo, "gym:Pendulum-v1", preset).agent
    paper = make_config("hi-ddpg", "gym:Reacher-v5", "paper")
    assert paper.agent.high.hidden == (300, 300) and paper.episodes == 3000
    agent = make_config("hi-ddpg", "gym:Reacher-v5", "quick").agent
    assert (agent.switch_cost, agent.choice, agent.high.end_is_terminal) == (0.0, ActorChoice(),
                                                                            False)
    assert not agent.high.noise.decays and agent.low.env_terminal


@pytest.mark.parametrize("argv, message", [
    (["hi-ddpg", "Pendulum-v1"], r"hi-ddpg needs a goal space and gym:Pendulum-v1 declares "
     r"none: .*indices 0\.\.2\), on the command line one --goal INDEX:LOW:HIGH per entry"),
    (["h-ddpg", "gym:Pendulum-v1"], r"h-DDPG has no skill patterns for gym:Pendulum-v1: .*"
     r"--skills MODULE:FUNCTION"),
    (["ddpg", "CartPole-v1"], r"gym:CartPole-v1: the action space is Discrete\(2\); .*a "
     r"discrete action space cannot work"),
    (["hi-ddpg", "Pendulum-v1", "--goal", "3:-1:1"],
     r"gym:Pendulum-v1: goal index 3 is outside the observation \(obs_dim=3: indices 0\.\.2\)"),
    (["hi-ddpg", "Pendulum-v1", "--goal", "0:1:-1"], r"--goal '0:1:-1': LOW 1 must be below "
     r"HIGH -1"),
    (["hi-ddpg", "Pendulum-v1", "--goal", "0:1"], r"--goal '0:1': give INDEX:LOW:HIGH"),
    (["hi-ddpg", "Pendulum-v1", "--goal", "0:0:1", "--goal", "0:0:2"], r"--goal '0:0:2': index "
     r"0 is declared twice"),
    (["ddpg", "Pendulm-v1"], r"unknown task 'Pendulm-v1': .*did you mean Pendulum-v1"),
    (["ddpg", "gym:Pendulm-v1"], r"unknown task 'gym:Pendulm-v1': .*did you mean Pendulum-v1"),
    (["hi-ddpg", "PuckTrajectory1", "--goal", "0:0:1"], r"--goal declares a Gymnasium task's "
     r"goal or skills; 'PuckTrajectory1' is one of ours"),
    (["h-ddpg", "Pendulum-v1", "--skills", "no_such_module_x:f"],
     r"--skills 'no_such_module_x:f': cannot import module"),
    (["--resume", ".", "--goal", "0:0:1"], r"--resume takes the run's config from \.; drop "
     r"--goal"),
])
def test_what_cannot_work_is_one_line_and_exit_2(argv, message, tmp_path, capsys):
    assert train_cmd.main([*argv, "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert re.search("^hiddpg train: error: " + message, err), err
    assert not (tmp_path / "out").exists()
    assert "Pendulum-v1" not in GYM_TASKS


@pytest.fixture(scope="module")
def line_run(tmp_path_factory):
    """A run directory of DDPG on ``line_env:LineWorld-v0``, seeds 0-1, as ``hiddpg train``
    makes it, with an untrained checkpoint (evaluating and drawing need no training; the
    Reacher test trains and resumes through the command line)."""
    path = tmp_path_factory.mktemp("gym-cli") / "line"
    with declarations_scope():
        config = make_config("ddpg", resolve_task(TASK), "quick", ["agent.hidden=[8,8]"])
        run = prepare_new(config, [0, 1], path)
        trainer = make_trainer(config)
        run.save_checkpoint(run.initial_state(trainer))
        run.write_progress(0, 0.0, "interrupted")
        run.close()
    return path


def table(capsys, *argv):
    assert cli.main(["eval", *argv]) == 0
    out = capsys.readouterr().out.splitlines()
    rows = {line.split()[0]: [float(v) for v in line.split()[1:]] for line in out
            if line.split() and line.split()[0].isdigit()}
    return rows, out


def test_eval_replays_and_draws_with_the_envs_frames(line_run, tmp_path, capsys):
    ref = str(line_run)
    first, _ = table(capsys, ref)
    assert set(first) == {"0", "1"} and np.all(np.isfinite(list(first.values())))
    assert [row[3] for row in first.values()] == [10, 10]  # length: the TimeLimit
    rows, out = table(capsys, ref, "--seed", "1", "--gif", str(tmp_path / "g" / "one.gif"))
    assert rows == {"1": first["1"]} and out[-1] == f"wrote {tmp_path / 'g' / 'one.gif'}"
    assert not [line for line in out if line.startswith("note:")]  # replayed exactly
    gif = Image.open(tmp_path / "g" / "one.gif")
    assert gif.n_frames == 11 and gif.size[0] == 40 and gif.size[1] > 12  # + the text strip
    env = open_renderer(make_host_env("gym:" + TASK))
    env.reset(seed=reset_seed(eval_keys(0, [0, 1])[1]))  # seed 1's evaluation episode
    expected = env.render()  # its target (red) and the point at 0 (blue)
    env.close()
    for k in range(11):  # the untrained actor barely moves (its last layer starts at ±3e-3)
        gif.seek(k)
        frame = np.asarray(gif.convert("RGB"))[:12].astype(int)
        np.testing.assert_allclose(frame, expected, atol=8)


@pytest.mark.filterwarnings("ignore:.*render_mode='rgb_array' that is not in the possible")
def test_a_gif_needs_an_env_that_draws_rgb_array(line_run, tmp_path, capsys):
    blind = tmp_path / "blind"
    shutil.copytree(line_run, blind)
    meta = json.loads((blind / "config.json").read_text())
    meta["config"]["task"] = "gym:line_env:BlindLine-v0"
    meta["gym_task"]["env"] = "line_env:BlindLine-v0"
    (blind / "config.json").write_text(json.dumps(meta))
    assert cli.main(["eval", str(blind), "--gif", str(tmp_path / "b.gif")]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err == ("hiddpg eval: error: --gif: gym:line_env:BlindLine-v0 cannot "
                                 "draw rgb_array frames (its render modes: none); without "
                                 "--gif hiddpg eval prints its evaluation\n")
    assert not (tmp_path / "b.gif").exists()

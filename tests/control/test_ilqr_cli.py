"""``hiddpg ilqr``: the JSON's numbers (shapes, cost, optimality, final position), the GIF, the
printed report and the exit-2 errors for bad goals, switch times and options."""

from __future__ import annotations

import contextlib
import io
import json

import jax.numpy as jnp
import numpy as np
import pytest
from PIL import Image

from hiddpg import cli, make
from hiddpg.commands import ilqr as ilqr_cmd
from hiddpg.control import goal_tracking_cost
from hiddpg.envs.puckworld import dynamics

TASK = "PuckTrajectory2"


def run_cli(argv):
    """``(exit code, stdout, stderr)`` of ``hiddpg ilqr ARGV`` in this process."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = cli.main(["ilqr", *argv])
    return code, out.getvalue(), err.getvalue()


@pytest.fixture(scope="module")
def solved(tmp_path_factory):
    """One solve with the task's reference goals, writing both the JSON and the GIF."""
    root = tmp_path_factory.mktemp("ilqr")
    code, out, err = run_cli([TASK, "--json", str(root / "sol.json"),
                              "--gif", str(root / "sol.gif")])
    assert code == 0, err
    data = json.loads((root / "sol.json").read_text())
    return {"data": data, "out": out, "gif": root / "sol.gif"}


@pytest.fixture(scope="module")
def task():
    return make(TASK)


def _cost(data):
    return goal_tracking_cost(jnp.asarray(data["goals"], jnp.float32), data["switch_times"],
                              data["horizon"], data["goal_indices"], weight=data["weight"],
                              action_weight=data["action_weight"])


def test_json_defaults_are_the_tasks_reference(solved, task):
    _, params = task
    data = solved["data"]
    assert data["horizon"] == params.max_steps == 30
    np.testing.assert_allclose(data["goals"], params.goals)
    assert data["switch_times"] == [15]
    # the reference controller's effort weight 0.03 |F|^2 in normalised actions (F = 10 a)
    assert data["action_weight"] == pytest.approx(3.0)


def test_json_actions_and_states(solved, task):
    env, params = task
    data = solved["data"]
    actions, states = np.asarray(data["actions"]), np.asarray(data["states"])
    assert actions.shape == (data["horizon"], env.action_dim)
    assert states.shape == (data["horizon"] + 1, env.state_dim)
    assert np.all(np.abs(actions) <= 1.0 + 1e-6)
    np.testing.assert_allclose(states[0], params.init_state)
    # the states are the task's own dynamics driven by the actions
    x, rolled = jnp.asarray(states[0], jnp.float32), []
    for a in actions:
        x = dynamics(x, jnp.asarray(a, jnp.float32), params)
        rolled.append(np.asarray(x))
    np.testing.assert_allclose(np.stack(rolled), states[1:], atol=1e-5)
    np.testing.assert_allclose(data["final_state"], states[-1])


def test_final_position_near_the_references(solved, task):
    _, params = task
    final = np.asarray(solved["data"]["final_state"])[:2]
    ref_final = np.asarray(params.ref_states[-1, :2])
    # iLQR anticipates the switch that the reference's LQR does not: close, not equal (0.20 m)
    assert np.linalg.norm(final - ref_final) < 0.25
    assert np.linalg.norm(final - np.asarray(params.goals[-1])) < 0.3


def test_cost_is_the_tracking_cost_and_beats_the_reference(solved, task):
    _, params = task
    data = solved["data"]
    cost = _cost(data)
    total = float(cost.total(jnp.asarray(data["states"], jnp.float32),
                             jnp.asarray(data["actions"], jnp.float32)))
    assert data["cost"] == pytest.approx(total, rel=1e-5)
    ref_states = jnp.concatenate([params.init_state[None], params.ref_states])
    ref_cost = float(cost.total(ref_states, params.ref_actions))
    assert data["cost"] < 0.5 * ref_cost  # the optimum of the cost vs the reference's actions
    history = np.asarray(data["cost_history"])
    assert len(history) == data["iterations"] + 1 and data["converged"]
    assert data["iterations"] <= 3  # linear-quadratic: LQR after one iteration
    assert np.all(np.diff(history) <= 1e-6 * history[0])
    assert history[-1] == pytest.approx(data["cost"], rel=1e-6)


def test_env_return_is_the_tasks_reward(solved, task):
    _, params = task
    data = solved["data"]
    positions = np.asarray(data["states"])[1:, :2]
    rewards = -params.tracking_weight * np.linalg.norm(
        positions - np.asarray(params.ref_states[:, :2]), axis=1)
    np.testing.assert_allclose(data["rewards"], rewards, atol=1e-5)
    assert data["env_return"] == pytest.approx(rewards.sum(), abs=1e-4)
    assert data["episode_steps"] == 30


def test_gif_has_one_frame_per_state(solved):
    with Image.open(solved["gif"]) as gif:
        assert gif.n_frames == solved["data"]["horizon"] + 1 == 31


def test_printed_report(solved):
    out, data = solved["out"], solved["data"]
    assert f"iterations   {data['iterations']}" in out
    assert "converged    True" in out
    assert f"cost         {data['cost']:.6g}" in out
    history = [line for line in out.splitlines() if line.strip()[:1].isdigit() and ":" in line]
    assert len(history) == data["iterations"] + 1
    assert float(history[-1].split(":")[1]) == pytest.approx(data["cost"], rel=1e-5)
    assert "(31 frames)" in out


def test_own_goal_and_horizon(tmp_path):
    path = tmp_path / "one.json"
    code, _, err = run_cli([TASK, "--goals=1.5,-0.5", "--horizon", "20",
                            "--action-weight", "0.03", "--json", str(path)])
    assert code == 0, err
    data = json.loads(path.read_text())
    assert np.asarray(data["actions"]).shape == (20, 2) and data["switch_times"] == []
    # cheap actions: the puck ends on the goal
    np.testing.assert_allclose(np.asarray(data["final_state"])[:2], [1.5, -0.5], atol=1e-2)
    total = float(_cost(data).total(jnp.asarray(data["states"], jnp.float32),
                                    jnp.asarray(data["actions"], jnp.float32)))
    assert data["cost"] == pytest.approx(total, rel=1e-5)


@pytest.mark.parametrize("argv, named, says", [
    (["--goals", "1,0;2,0", "--switch-times", "10,20"], "--switch-times", "1 strictly"),
    (["--switch-times", "40"], "--switch-times", "[1, 29]"),
    (["--switch-times", "0"], "--switch-times", "outside the horizon"),
    (["--goals", "1,0;2,0;2.5,1", "--switch-times", "20,10"], "--switch-times", "increasing"),
    (["--goals", "1,2,3"], "--goals", "have 2"),
    (["--goals", "1,0;2"], "--goals", "goal 2 has 1"),
    (["--goals", "1,x"], "--goals", "numbers"),
    (["--goals", "5,0"], "--goals", "goal space"),
    (["--horizon", "10"], "--switch-times", "[1, 9]"),
    (["--goals", "1,0;2,0;2,1", "--horizon", "2"], "--horizon", "too short"),
    (["--horizon", "0"], "--horizon", ">= 1"),
    (["--action-weight", "-1"], "--action-weight", "> 0"),
    (["--set", "dt=-1"], "--set", "dt"),
    (["--horizon", "many"], "--horizon", ""),
])
def test_bad_inputs_exit_2_naming_the_parameter(argv, named, says):
    code, out, err = run_cli([TASK, *argv])
    assert code == 2
    assert named in err and says in err
    assert "iterations" not in out


def test_unknown_task_exits_2():
    code, _, err = run_cli(["PuckTrajectory9"])
    assert code == 2 and "PuckTrajectory9" in err


def test_main_is_callable_directly():
    assert ilqr_cmd.main(["--help"]) == 0

"""The line a finished run ends with (hiddpg.summary): the final evaluation's environment return
beside the reference plan's and a random policy's, with the right grammar for one seed and
several; the baselines' numbers against direct rollouts."""

from __future__ import annotations

import jax
import numpy as np
import pytest

from hiddpg.envs import make
from hiddpg.presets import make_config
from hiddpg.runs import Run
from hiddpg.summary import (
    RANDOM_EPISODES,
    number,
    random_keys,
    random_policy_return,
    reference_return,
    result_line,
)

ARGS = ["episodes=20", "eval_every=10", "chunk_episodes=10"]


def config(task: str = "PuckTrajectory1", *extra: str):
    return make_config("hi-ddpg", task, "quick", ARGS + list(extra))


def direct_random_return(task: str, key, **overrides) -> float:
    """One episode of uniform random actions, stepped eagerly in Python, keys split as
    :func:`hiddpg.summary.episode_return` documents; stops at the episode's end."""
    core, params = make(task, **overrides)
    reset_key, run_key = jax.random.split(key)
    _, state = core.reset(reset_key, params)
    total = 0.0
    for step_key in jax.random.split(run_key, core.max_steps(params)):
        act_key, env_key = jax.random.split(step_key)
        action = jax.random.uniform(act_key, (core.action_dim,), minval=core.action_low,
                                    maxval=core.action_high)
        res = core.step(env_key, state, action, params)
        total += float(res.reward)
        if bool(res.terminated) or bool(res.truncated):
            break
        state = res.state
    return total


def fake_run(tmp_path, seeds, finals, *, env_column=True, cfg=None) -> Run:
    """A run directory whose two evaluations (episodes 10 and 20) return ``finals`` last; the
    agent's own evaluation return is 100 lower (HI-DDPG's switch costs)."""
    run = Run.create(tmp_path / "run", cfg or config(), seeds)
    n = len(seeds)
    ep = np.arange(1, 21, dtype=np.int32)[None].repeat(n, 0)
    train = {"episode": ep, "return": np.zeros(ep.shape, np.float32),
             "env_return": np.zeros(ep.shape, np.float32), "length": np.full_like(ep, 30),
             "switches": np.zeros_like(ep)}
    last = np.asarray(finals, np.float32)[:, None]
    env = np.concatenate([last - 50.0, last], axis=1)
    evals = {"episode": ep[:, [9, 19]], "return": env - 100.0}
    if env_column:
        evals["env_return"] = env
    run.append_metrics(train, evals)
    return run


@pytest.fixture(scope="module")
def random_mean() -> float:
    return float(random_policy_return(config(), random_keys()).mean())


def test_result_line_for_one_seed(tmp_path, random_mean):
    run = fake_run(tmp_path, [4], [-5.016])
    assert result_line(run, 63.21) == (
        f"final evaluation: environment return -5.02 (seed 4); reference plan 0.00, random "
        f"policy {number(random_mean)} | wall 63.2 s | run {run.path}")
    assert "±" not in result_line(run, 1.0)


def test_result_line_for_three_seeds(tmp_path, random_mean):
    finals = [-5.0, -7.0, -12.0]
    run = fake_run(tmp_path, [0, 1, 2], finals)
    std = np.std(finals, ddof=1)
    assert result_line(run, 5.0) == (
        f"final evaluation: environment return -8.00 ± {std:.2f} (mean ± std over 3 seeds); "
        f"reference plan 0.00, random policy {number(random_mean)} | wall 5.0 s | "
        f"run {run.path}")


def test_result_line_without_a_reference_plan(tmp_path):
    cfg = make_config("ddpg", "PuckObstacle", "quick", ARGS)
    run = fake_run(tmp_path, [0, 1], [-30.0, -40.0], cfg=cfg)
    random = float(random_policy_return(cfg, random_keys()).mean())
    line = result_line(run, 1.0)
    assert "reference plan" not in line
    assert f"(mean ± std over 2 seeds); random policy {number(random)} |" in line


def test_result_line_without_the_environment_return(tmp_path):
    run = fake_run(tmp_path, [0], [-5.0], env_column=False)
    assert result_line(run, 2.0) == (f"final evaluation: return -105 (seed 0) | wall 2.0 s "
                                     f"| run {run.path}")


def test_result_line_without_an_evaluation(tmp_path):
    run = Run.create(tmp_path / "empty", config(), [0])
    assert result_line(run, 0.0) == f"no evaluation recorded | wall 0.0 s | run {run.path}"


def test_random_policy_return_is_a_rollout_of_random_actions():
    keys = jax.random.split(jax.random.PRNGKey(3), 3)
    got = random_policy_return(config(), keys)
    want = [direct_random_return("PuckTrajectory1", k) for k in keys]
    np.testing.assert_allclose(got, want, rtol=1e-4, atol=1e-3)
    assert len(set(np.round(got, 3))) == 3  # different keys, different episodes


def test_random_policy_return_ends_with_the_episode_and_follows_env_overrides():
    # PuckObstacle ends at a collision: the rollout keeps stepping but counts no more reward
    keys = jax.random.split(jax.random.PRNGKey(1), 4)
    got = random_policy_return(make_config("ddpg", "PuckObstacle", "quick", ARGS), keys)
    want = [direct_random_return("PuckObstacle", k) for k in keys]
    np.testing.assert_allclose(got, want, rtol=1e-4, atol=1e-3)
    short = random_policy_return(config("PuckTrajectory1", "env.max_steps=5"), keys)
    want = [direct_random_return("PuckTrajectory1", k, max_steps=5) for k in keys]
    np.testing.assert_allclose(short, want, rtol=1e-4, atol=1e-3)


def test_the_reference_plan_beats_a_random_policy_on_puck_trajectory_1(random_mean):
    reference = reference_return(config())
    assert reference == pytest.approx(0.0, abs=1e-3)  # it draws the reference trajectory
    assert len(random_keys()) == RANDOM_EPISODES
    assert random_mean < reference - 40.0  # measured: -64.7
    assert reference_return(config("PuckTrajectory1", "env.max_steps=5")) == pytest.approx(
        0.0, abs=1e-3)


@pytest.mark.parametrize("task", ["PuckObstacle", "ArmReach", "ArmObstacle"])
def test_tasks_without_a_reference_plan(task):
    assert reference_return(make_config("ddpg", task, "quick", ARGS)) is None


def test_number():
    assert [number(x) for x in (-1e-7, -5.016, -41.27, -123.4, 0.0, 7.0)] == [
        "0.00", "-5.02", "-41.3", "-123", "0.00", "7.00"]

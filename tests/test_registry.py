"""A user's environment registered from outside the package (tests/user_env): all four
algorithms through the Python API and the CLI, Gymnasium, iLQR, and the registry's errors.
The tasks registered here are unregistered at the end, so other test modules see the built-ins
only."""

from __future__ import annotations

import csv
import importlib
import json
import os
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import jax
import numpy as np
import pytest

import hiddpg
from hiddpg import algorithms, cli
from hiddpg.configs import ALGORITHMS, HI_DDPG_ALGORITHMS, HIDDPGConfig
from hiddpg.envs import TASKS, register_task, task_name, unregister_task
from hiddpg.presets import PUCK, make_config, task_family
from hiddpg.runs import Run
from hiddpg.train import Trainer, make_train

TESTS = Path(__file__).parent
EPISODES = ["episodes=4", "eval_every=2", "chunk_episodes=4"]
#: tiny networks and batches, learning from environment step 20 (episode 1 of 40 steps)
TINY = {
    "ddpg": ["agent.hidden=[16,16]", "agent.learning_starts=20", "agent.batch_size=16"],
    "hi-ddpg": ["agent.high.hidden=[16,16]", "agent.low.hidden=[16,16]",
                "agent.learning_starts=20", "agent.high_learning_starts=4",
                "agent.pretrain_episodes=1", "agent.high.batch_size=4",
                "agent.low.batch_size=16"],
    "h-ddpg": ["agent.skill.hidden=[16,16]", "agent.meta.hidden=[16,16]",
               "agent.skill.learning_starts=20", "agent.skill.batch_size=16",
               "agent.meta.batch_size=16"],
}
TINY["hi-ddpg-wo-model"] = TINY["hi-ddpg"]
#: losses that are positive once an algorithm learns
LOSSES = {"ddpg": ("critic_loss", "actor_loss"),
          "hi-ddpg": ("low_critic_loss", "high_critic_loss", "low_model_loss", "high_model_loss"),
          "hi-ddpg-wo-model": ("low_critic_loss", "high_critic_loss"),
          "h-ddpg": ("meta_loss", "skill_critic_loss", "skill_actor_loss")}


@pytest.fixture(scope="module", autouse=True)
def slider():
    """The user's module, imported here (it registers ``Slider``); every task registered in
    this module is unregistered afterwards."""
    before = set(TASKS)
    module = importlib.import_module("user_env.slider")
    if "Slider" not in TASKS:  # imported and cleaned up before
        importlib.reload(module)
    yield module
    for name in set(TASKS) - before:
        unregister_task(name)


def cli_env() -> dict[str, str]:
    path = os.pathsep.join([str(TESTS), os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    return {**os.environ, "PYTHONPATH": path}


# -- the Python API -----------------------------------------------------------------------------
def test_the_registry_declares_the_algorithms_and_the_builtin_tasks():
    assert ALGORITHMS == ("ddpg", "hi-ddpg", "hi-ddpg-wo-model", "h-ddpg")
    assert HI_DDPG_ALGORITHMS == ("hi-ddpg", "hi-ddpg-wo-model")
    assert [task_family(t) for t in ("PuckTrajectory2", "PuckObstacle", "ArmReach")] == [
        "puck", "puck", "arm"]
    with pytest.raises(ValueError, match="unknown algorithm 'ppo'.*h-ddpg"):
        make_config("ppo", "Slider")


def test_a_custom_task_gets_the_puck_values():
    assert task_family("Slider") == "custom"
    paper, quick = make_config("ddpg", "Slider"), make_config("hi-ddpg", "Slider", "quick")
    assert paper.agent.hidden == PUCK.hidden and paper.agent.noise.sigma == PUCK.sigma
    assert (paper.episodes, paper.eval_every, paper.chunk_episodes) == (3000, 20, 200)
    assert quick.agent.pretrain_episodes == PUCK.quick_pretrain_episodes
    assert quick.agent.switch_cost == 0.0 and not quick.agent.high.end_is_terminal


@pytest.mark.parametrize("algo", ALGORITHMS)
def test_every_algorithm_learns_on_the_user_task(algo):
    config = make_config(algo, "hiddpg/Slider-v0", "quick", [*EPISODES, *TINY[algo]])
    assert config.task == "Slider"
    state, train_metrics, eval_metrics = jax.jit(make_train(config))(jax.random.PRNGKey(0))
    returns = np.asarray(train_metrics["return"])
    assert returns.shape == (4,) and np.all(np.isfinite(returns)) and np.all(returns < 0)
    assert np.all(np.isfinite(np.asarray(eval_metrics["return"])))
    assert int(np.asarray(state.agent.env_steps).max()) == 4 * 40
    for name in LOSSES[algo]:  # learning starts in episode 1 (two for HI-DDPG's high level)
        assert np.all(np.asarray(train_metrics[name])[1:] > 0), name
    if algo == "hi-ddpg-wo-model":
        assert not np.any(np.asarray(train_metrics["low_model_loss"]))


def test_h_ddpg_uses_the_declared_skills_and_refuses_a_task_without(slider):
    trainer = Trainer(make_config("h-ddpg", "Slider", "quick"))
    assert trainer.agent.patterns.names == ("right", "left")
    register_task("SliderNoSkills", slider.Slider)
    with pytest.raises(ValueError, match="task 'SliderNoSkills'.*register_task.*skills="):
        Trainer(make_config("h-ddpg", "SliderNoSkills", "quick"))


def test_hi_ddpg_needs_a_goal_space(slider):
    class NoGoals(slider.Slider):
        goal_space = None

    register_task("SliderNoGoals", NoGoals)
    Trainer(make_config("ddpg", "SliderNoGoals", "quick"))
    with pytest.raises(ValueError, match="hi-ddpg needs a goal space: NoGoals.goal_space is None"):
        Trainer(make_config("hi-ddpg", "SliderNoGoals", "quick"))


# -- registration -------------------------------------------------------------------------------
def test_registering_again_is_idempotent_and_a_different_entry_is_refused(slider):
    spec, skills = TASKS["Slider"], slider.slider_skills
    assert hiddpg.register_task("Slider", "user_env.slider:Slider", skills=skills,
                                summary=spec.summary) is spec
    with pytest.raises(ValueError, match="'Slider' is already registered.*another name"):
        register_task("Slider", lambda: slider.Slider(), skills=skills)
    with pytest.raises(ValueError, match="'Slider' is already registered"):
        register_task("Slider", slider.Slider, skills=skills, family="arm")
    with pytest.raises(ValueError, match="'PuckObstacle' is already registered"):
        register_task("PuckObstacle", slider.Slider)
    with pytest.raises(ValueError, match="'PuckObstacle' is a built-in task"):
        unregister_task("PuckObstacle")


@pytest.mark.parametrize("entry, message", [
    ("user_env.slider:SliderParams", "SliderParams is not a subclass of hiddpg.envs.Environment"),
    ("no_such_module:Env", "cannot import module 'no_such_module'"),
    ("user_env.slider:Nothing", "has no attribute 'Nothing'"),
    (42, "must be a 'module:Class' string.*got int"),
    (lambda: 3, "the factory returned int, not a hiddpg.envs.Environment"),
    ("instance", "an Environment instance; pass its class Slider"),
])
def test_a_bad_entry_is_refused_naming_it(slider, entry, message):
    entry = slider.Slider() if entry == "instance" else entry
    with pytest.raises(ValueError, match=message):
        register_task("Bad", entry)
    assert "Bad" not in TASKS


def test_bad_names_families_and_declarations_are_refused(slider):
    for name in ("bad/name", "Bad-v0", "", "1up"):
        with pytest.raises(ValueError, match="the name must start with a letter"):
            register_task(name, slider.Slider)
    with pytest.raises(ValueError, match="family='fish' is unknown.*'custom'"):
        register_task("Fish", slider.Slider, family="fish")
    with pytest.raises(ValueError, match="skills=3 is not callable"):
        register_task("Fish", slider.Slider, skills=3)
    assert "Fish" not in TASKS


def test_a_module_class_id_is_imported_and_registered_under_its_class_name():
    assert task_name("user_env.slider:Slider") == "Slider"  # registered by its module
    assert task_name("user_env:Ramp") == "Ramp" and TASKS["Ramp"].target == "user_env:Ramp"
    assert TASKS["Ramp"].load() is sys.modules["user_env"].Ramp and TASKS["Ramp"].skills is None
    with pytest.raises(ValueError, match="unknown task 'user_env:Nope'.*no attribute 'Nope'"):
        task_name("user_env:Nope")


# -- Gymnasium and iLQR -------------------------------------------------------------------------
def test_gymnasium_makes_a_registered_task(slider):
    env = gym.make("hiddpg/Slider-v0", target=0.25)
    obs, _ = env.reset(seed=0)
    assert obs.shape == (2,) and env.unwrapped.params == slider.SliderParams(target=0.25)
    obs, reward, terminated, truncated, _ = env.step(np.array([1.0], np.float32))
    np.testing.assert_allclose(obs, [0.0, 0.1])
    np.testing.assert_allclose(reward, -0.25)  # the position moves from the second step
    assert env.observation_space.high.tolist() == [1e4, 1e4]

    def bounds(core, params):
        return np.array([-2.0, -5.0]), np.array([2.0, 5.0])

    register_task("BoxedSlider", slider.Slider, obs_bounds=bounds)
    assert gym.make("hiddpg/BoxedSlider-v0").observation_space.high.tolist() == [2.0, 5.0]


def test_ilqr_brings_the_user_task_to_its_target(tmp_path, capsys):
    out = tmp_path / "ilqr.json"
    assert cli.main(["ilqr", "user_env.slider:Slider", "--json", str(out)]) == 0
    solution = json.loads(out.read_text())
    assert solution["task"] == "Slider" and solution["goals"] == [[0.5]]
    np.testing.assert_allclose(solution["final_state"], [0.5, 0.0], atol=1e-3)


# -- the command line ---------------------------------------------------------------------------
def metrics(run_dir: Path) -> list[dict[str, str]]:
    with open(run_dir / "metrics.csv", newline="") as f:
        return list(csv.DictReader(f))


def test_cli_trains_an_unregistered_class_in_process(tmp_path):
    argv = ["train", "ddpg", "user_env:Ramp", "--preset", "quick", "--seeds", "0-1",
            *[a for s in EPISODES + TINY["ddpg"] for a in ("--set", s)],
            "--out", str(tmp_path), "--name", "ramp"]
    assert cli.main(argv) == 0
    rows = metrics(tmp_path / "ramp")
    assert sorted((r["seed"], r["episode"]) for r in rows) == [
        (s, e) for s in ("0", "1") for e in ("1", "2", "3", "4")]
    assert sorted(r["episode"] for r in rows if r["eval_return"]) == ["2", "2", "4", "4"]
    assert all(float(r["critic_loss"]) > 0 for r in rows if r["episode"] != "1")


@pytest.mark.heavy  # CI: the CLI in process below, the README's commands in fresh processes
def test_cli_trains_h_ddpg_in_a_fresh_process_and_resumes(tmp_path):
    argv = ["train", "h-ddpg", "user_env.slider:Slider", "--preset", "quick", "--seeds", "0-1",
            *[a for s in EPISODES + TINY["h-ddpg"] for a in ("--set", s)],
            "--out", str(tmp_path), "--name", "cli"]
    done = subprocess.run([sys.executable, "-m", "hiddpg.cli", *argv], env=cli_env(),
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    run_dir = tmp_path / "cli"
    assert len(metrics(run_dir)) == 2 * 4
    meta = json.loads((run_dir / "config.json").read_text())
    assert meta["task"]["target"] == "user_env.slider:Slider"
    assert meta["task"]["skills"] == "user_env.slider:slider_skills"
    assert Run.open(run_dir).config.task == "Slider"
    assert cli.main(["train", "--resume", str(run_dir), "--episodes", "6"]) == 0
    rows = metrics(run_dir)
    assert len(rows) == 2 * 6 and all(np.isfinite(float(r["return"])) for r in rows)
    assert all(float(r["meta_loss"]) > 0 for r in rows if r["episode"] != "1")


def test_the_algorithm_registry_refuses_a_taken_name():
    ddpg = algorithms.get_algorithm("ddpg")
    assert algorithms.register_algorithm(ddpg) is ddpg
    with pytest.raises(ValueError, match="algorithm 'ddpg' is already registered"):
        algorithms.register_algorithm(algorithms.Algorithm("ddpg", HIDDPGConfig, ddpg.factory,
                                                           ddpg.presets))

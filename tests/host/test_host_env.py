"""What a Gymnasium task looks like to the agents (:mod:`hiddpg.host.env`) and the declarations
(:mod:`hiddpg.host.task`): sizes, action box and its affine map, horizon, ``dt``, goal spaces
and skills; one-line errors for what cannot work. Nothing here compiles a training step."""

from __future__ import annotations

import dataclasses
import json

import gymnasium as gym
import numpy as np
import pytest

from hiddpg.agents import make_agent
from hiddpg.agents.skills import ArmSkills, PuckSkills
from hiddpg.configs import TrainConfig
from hiddpg.envs import GoalSpace
from hiddpg.host import (
    GymTask,
    HostTrainer,
    gym_task,
    is_gym_task,
    make_host_env,
    register_gym_task,
    unregister_gym_task,
)
from hiddpg.host.task import restore_gym_task
from hiddpg.presets import make_config
from hiddpg.train import make_trainer


class Line(gym.Env):
    """A 1-D point that moves by its action; spaces as given."""

    def __init__(self, action_space=None, observation_space=None):
        self.action_space = action_space or gym.spaces.Box(-1.0, 1.0, (1,), np.float32)
        self.observation_space = observation_space or gym.spaces.Box(-9.0, 9.0, (2,),
                                                                     np.float32)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        return np.zeros(2, np.float32), {}

    def step(self, action):
        return np.zeros(2, np.float32), 0.0, False, False, {}


@pytest.fixture
def declared():
    """Names registered by a test, unregistered after it."""
    names: list[str] = []
    yield names
    for name in names:
        unregister_gym_task(name)


def one_line(info: pytest.ExceptionInfo) -> str:
    text = str(info.value)
    assert "\n" not in text and "Traceback" not in text
    return text


def test_an_adapter_brings_its_core_description():
    env = make_host_env("gym:hiddpg/PuckTrajectory1-v0")
    assert (env.obs_dim, env.action_dim, env.horizon) == (4, 2, 30)
    assert (env.action_low, env.action_high) == (-1.0, 1.0)
    assert env.goal_space == GoalSpace((0, 1), (-1.0, -2.5), (3.0, 2.5))
    assert env.dt == env.core.dt and env.params.max_steps == 30
    assert env.declared_skills(make_config("h-ddpg", "PuckTrajectory1").agent) == PuckSkills()
    arm = make_host_env("gym:hiddpg/ArmReach-v0", max_steps=20)  # kwargs reach the core
    assert (arm.action_low, arm.action_high, arm.horizon) == (0.0, 1.0, 20)
    action = np.array([[0.0, 0.25, 1.0, 0.5, 0.75, 1.0]], np.float32)
    np.testing.assert_array_equal(arm.to_box(action), action)  # the adapter's box: identity


def test_a_foreign_env_acts_in_the_unit_box_mapped_onto_its_box():
    env = make_host_env("gym:Pendulum-v1")  # Box [-2, 2], TimeLimit 200, dt attribute 0.05
    assert (env.obs_dim, env.action_dim, env.horizon, env.dt) == (3, 1, 200, 0.05)
    assert (env.action_low, env.action_high) == (-1.0, 1.0)
    assert env.goal_space is None and env.core is None
    out = env.to_box(np.array([[-1.0], [0.0], [0.5], [1.0], [1.0000001]], np.float32))
    assert out.dtype == np.float32
    np.testing.assert_array_equal(out[:, 0], [-2.0, 0.0, 1.0, 2.0, 2.0])


def test_a_declared_goal_horizon_and_dt(declared):
    declared.append("Pendulum-v1")
    task = register_gym_task("Pendulum-v1", goal={1: (-1, 1), 0: (-1, 1)},
                             max_episode_steps=50, dt=0.1)
    assert register_gym_task("Pendulum-v1", goal=GoalSpace((0, 1), (-1, -1), (1, 1)),
                             max_episode_steps=50, dt=0.1) == task  # the same declaration
    assert gym_task("gym:Pendulum-v1") is task and is_gym_task("gym:Pendulum-v1")
    env = make_host_env("gym:Pendulum-v1")
    assert env.goal_space == GoalSpace((0, 1), (-1.0, -1.0), (1.0, 1.0))
    assert (env.horizon, env.dt) == (50, 0.1)
    vec = env.make_vector(2)
    vec.reset(seed=[0, 1])
    for _ in range(49):
        _, _, terminated, truncated, _ = vec.step(np.zeros((2, 1), np.float32))
        assert not truncated.any()
    _, _, terminated, truncated, _ = vec.step(np.zeros((2, 1), np.float32))
    assert truncated.all() and not terminated.any()  # the declared TimeLimit truncates
    vec.close()


def test_a_factory_task(declared):
    declared.append("Line")
    register_gym_task("Line", lambda: Line(), max_episode_steps=7, summary="a line")
    env = make_host_env("gym:Line")
    assert (env.obs_dim, env.action_dim, env.horizon, env.dt) == (2, 1, 7, 1.0)
    assert not gym_task("gym:Line").goal


def test_a_declaration_is_recorded_and_restored(declared):
    declared.append("Line")
    task = register_gym_task("Line", Line, goal={1: (-1, 1)}, max_episode_steps=7,
                             skills="hiddpg.agents.skills:puck_skills", dt=0.5)
    data = json.loads(json.dumps(task.declaration()))  # as config.json holds it
    assert data["factory"] == f"{__name__}:Line" and data["goal"] == {"1": [-1.0, 1.0]}
    unregister_gym_task("Line")
    restore_gym_task("gym:Line", data)
    assert gym_task("gym:Line") == task
    assert GymTask("Pendulum-v1").declaration()["env"] == "Pendulum-v1"
    assert GymTask(lambda: Line()).declaration() is None  # a lambda cannot be named


@pytest.mark.parametrize("space, message", [
    (gym.spaces.Discrete(3), r"the action space is Discrete\(3\);.*a discrete action space "
                             "cannot work"),
    (gym.spaces.Box(-np.inf, np.inf, (2,)), r"the action Box is unbounded \(low=\[-inf, -inf\]"),
    (gym.spaces.Box(-1, 1, (2, 2)), r"the action Box has shape \(2, 2\); a 1-D Box is needed"),
])
def test_an_action_space_that_cannot_work(declared, space, message):
    declared.append("Bad")
    register_gym_task("Bad", lambda: Line(action_space=space), max_episode_steps=5)
    with pytest.raises(ValueError, match="^gym:Bad: " + message) as info:
        make_host_env("gym:Bad")
    one_line(info)


def test_an_observation_that_is_no_vector(declared):
    declared.append("Bad")
    obs = gym.spaces.Dict({"x": gym.spaces.Box(-1, 1, (2,))})
    register_gym_task("Bad", lambda: Line(observation_space=obs), max_episode_steps=5)
    with pytest.raises(ValueError, match="a 1-D Box is needed .*FlattenObservation") as info:
        make_host_env("gym:Bad")
    one_line(info)


def test_a_goal_index_outside_the_observation(declared):
    declared.append("Pendulum-v1")
    register_gym_task("Pendulum-v1", goal={0: (-1, 1), 3: (-1, 1)})
    with pytest.raises(ValueError, match=r"^gym:Pendulum-v1: goal index 3 is outside the "
                                         r"observation \(obs_dim=3: indices 0\.\.2\)$") as info:
        make_host_env("gym:Pendulum-v1")
    one_line(info)


@pytest.mark.parametrize("goal, message", [
    ({0: (1, -1)}, r"low\[0\]=1\.0 must be below high\[0\]=-1\.0"),
    ({0: "ab"}, r"must map observation indices to \(low, high\) pairs"),
    ([0, 1], r"must be a GoalSpace or a non-empty \{observation index: \(low, high\)\}"),
])
def test_a_malformed_goal(goal, message):
    with pytest.raises(ValueError, match=message) as info:
        GymTask("Pendulum-v1", goal=goal)
    one_line(info)


@pytest.mark.parametrize("kwargs, message", [
    ({"max_episode_steps": 0}, r"max_episode_steps=0 must be an int >= 1"),
    ({"dt": -1.0}, r"dt=-1\.0 must be a number > 0"),
    ({"vectorization": "ray"}, r"vectorization='ray' is not allowed; choose one of "
                               r"\['sync', 'async'\]"),
])
def test_a_malformed_declaration(kwargs, message):
    with pytest.raises(ValueError, match=message) as info:
        GymTask("Pendulum-v1", **kwargs)
    one_line(info)


def test_a_name_declared_twice_differently(declared):
    declared.append("Pendulum-v1")
    register_gym_task("Pendulum-v1", max_episode_steps=50)
    with pytest.raises(ValueError, match="already declared"):
        register_gym_task("Pendulum-v1", max_episode_steps=60)
    with pytest.raises(ValueError, match="without the 'gym:' prefix"):
        register_gym_task("gym:Pendulum-v1")


def test_unknown_ids_and_unknown_horizons(declared):
    with pytest.raises(ValueError, match="^gym:NoSuchEnv-v0: cannot make the environment: "
                                         ".*NoSuchEnv") as info:
        make_host_env("gym:NoSuchEnv-v0")
    one_line(info)
    with pytest.raises(ValueError, match="is not a host-engine task"):
        gym_task("Pendulum-v1")
    declared.append("Line")
    register_gym_task("Line", Line)
    with pytest.raises(ValueError, match=r"^gym:Line: the horizon is unknown \(no TimeLimit\); "
                                         r"declare it with .*max_episode_steps=N\)$"):
        make_host_env("gym:Line")
    with pytest.raises(ValueError, match=r"cannot make the environment: .*unexpected keyword"):
        make_host_env("gym:Pendulum-v1", no_such_argument=1)


def config(algo: str, task: str) -> TrainConfig:
    return dataclasses.replace(make_config(algo, "PuckTrajectory1", "quick"), task=task)


def test_hierarchical_agents_without_their_declarations():
    with pytest.raises(ValueError, match=r"^hi-ddpg needs a goal space and gym:Pendulum-v1 "
                                         r"declares none: .*indices 0\.\.2\), on the command "
                                         r"line one --goal INDEX:LOW:HIGH per entry, in Python "
                                         r".*register_gym_task\('Pendulum-v1', "
                                         r"goal=\{index: \(low, high\), \.\.\.\}\)$") as info:
        HostTrainer(config("hi-ddpg", "gym:Pendulum-v1"))
    one_line(info)
    with pytest.raises(ValueError, match=r"^h-DDPG has no skill patterns for gym:Pendulum-v1: "
                                         r"declare a factory .*--skills MODULE:FUNCTION, "
                                         r".*skills=\.\.\.\)") as info:
        make_trainer(config("h-ddpg", "gym:Pendulum-v1"))  # the run loop's trainer, too
    one_line(info)


def test_declared_skills_are_built_for_the_host_env(declared):
    seen = []

    def skills(env, config):
        seen.append(env)
        return (ArmSkills(agonists=((0,), (0,)), names=("+", "-")) if env.action_dim == 1
                else "no skills")

    declared.append("Pendulum-v1")
    register_gym_task("Pendulum-v1", skills=skills)
    env = make_host_env("gym:Pendulum-v1")
    agent = make_agent("h-ddpg", config("h-ddpg", "gym:Pendulum-v1").agent, env)
    assert agent.n_skills == 2 and seen == [env]
    declared.append("Line")
    register_gym_task("Line", lambda: Line(gym.spaces.Box(-1, 1, (2,))), max_episode_steps=5,
                      skills=skills)
    with pytest.raises(ValueError, match=r"the skills of gym:Line are a str, not a "
                                         r"hiddpg.agents.skills.SkillPatterns"):
        make_agent("h-ddpg", config("h-ddpg", "gym:Line").agent, make_host_env("gym:Line"))

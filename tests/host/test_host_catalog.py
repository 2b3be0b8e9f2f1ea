"""The shipped goals and skills (:mod:`hiddpg.host.catalog`): valid declarations, found by
``gym_task`` when nothing is registered and replaced by ``--goal``; the skills' actions; on
Reacher-v5 (``mujoco`` extra) and MyoSuite's elbow (``myosuite`` extra, its own virtualenv:
scripts/myosuite_venv.sh) the goal entries lie inside the observation and the skills fit the
action. Nothing is trained."""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
import types

import numpy as np
import pytest

from hiddpg.host import GYM_TASKS, gym_task
from hiddpg.host.catalog import (
    CATALOG,
    ELBOW_ENV,
    ELBOW_GOAL,
    ELBOW_MUSCLES,
    REACHER_GOAL,
    elbow_skills,
    reacher_skills,
)
from hiddpg.host.declare import declarations_scope, declare, value_sources
from hiddpg.host.task import GymTask, restore_gym_task


def _actions(skills, units):
    return np.array([np.asarray(skills.env_action(k, np.asarray(u, np.float32), None, None))
                     for k, u in enumerate(units)])


def test_the_declarations_are_valid_and_round_trip():
    for name, task in CATALOG.items():
        assert isinstance(task, GymTask) and task.goal is not None and task.summary
        data = json.loads(json.dumps(task.declaration()))
        assert data["skills"].startswith("hiddpg.host.catalog:")
        with declarations_scope():
            restore_gym_task("gym:" + name, data)
            assert GYM_TASKS[name] == task
        assert name not in GYM_TASKS and gym_task("gym:" + name) is task
    assert gym_task("gym:Pendulum-v1") == GymTask(env="Pendulum-v1")


def test_a_declaration_given_replaces_the_shipped_goal():
    with declarations_scope():
        declare("Reacher-v5", ["8:-0.3:0.3", "9:-0.3:0.3"])
        task = gym_task("gym:Reacher-v5")
        assert task.goal.low == (-0.3, -0.3) and task.skills == CATALOG["Reacher-v5"].skills
    assert gym_task("gym:Reacher-v5").goal.high == (REACHER_GOAL[8][1], REACHER_GOAL[9][1])


def test_the_skills_actions():
    reacher = reacher_skills(types.SimpleNamespace(action_dim=2), None)
    assert reacher.actor_dims == (2, 2, 2, 2)
    np.testing.assert_allclose(_actions(reacher, [[1, 0]] * 4),
                               [[1, 0.5], [1, -0.5], [-1, 0.5], [-1, -0.5]])
    np.testing.assert_allclose(_actions(reacher, [[-1, -1]] * 4), 0)
    elbow = elbow_skills(types.SimpleNamespace(action_dim=6), None)
    assert elbow.names == ("flex", "extend", "co-contract") and elbow.actor_dims == (3, 3, 1)
    np.testing.assert_allclose(_actions(elbow, [[1, 0, -1], [1, 0, -1], [0.5, 9, 9]]),
                               [[-1, -1, -1, 1, 0, -1], [1, 0, -1, -1, -1, -1], [0.5] * 6])
    with pytest.raises(ValueError, match="the elbow skills drive 6 actions"):
        elbow_skills(types.SimpleNamespace(action_dim=2, name="gym:X"), None)


def test_importing_the_catalogue_imports_no_simulator():
    code = ("import sys, hiddpg, hiddpg.host.catalog; "
            "print(sorted(m for m in ('mujoco', 'myosuite', 'gymnasium.envs.mujoco') "
            "if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "[]"


@pytest.mark.skipif(importlib.util.find_spec("mujoco") is None, reason="needs the mujoco extra")
def test_reacher_goal_and_skills_fit_the_environment():
    from hiddpg.configs import HDDPGConfig
    from hiddpg.host import make_host_env

    env = make_host_env("gym:Reacher-v5")
    assert env.obs_dim == 10 and max(env.goal_space.indices) < env.obs_dim
    assert env.goal_space.indices == (8, 9) and env.horizon == 50
    assert env.declared_skills(HDDPGConfig()).n_skills == 4
    config = types.SimpleNamespace(task="gym:Reacher-v5", preset="quick")
    shipped = value_sources(config, env)
    assert shipped["goal"]["from"] == shipped["skills_from"] == \
        "hiddpg.host.catalog (shipped with hiddpg)"
    assert shipped["goal"]["entries"] == {"8": list(REACHER_GOAL[8]), "9": list(REACHER_GOAL[9])}
    with declarations_scope():
        declare("Reacher-v5", ["8:-0.3:0.3", "9:-0.3:0.3"])
        given = value_sources(config, make_host_env("gym:Reacher-v5"))
    assert given["goal"]["from"] == "--goal / register_gym_task"
    assert given["skills_from"] == shipped["skills_from"]  # --skills not given: still shipped


@pytest.mark.skipif(importlib.util.find_spec("myosuite") is None,
                    reason="needs the myosuite extra (scripts/myosuite_venv.sh)")
def test_elbow_goal_and_skills_fit_the_environment():
    from hiddpg.configs import HDDPGConfig
    from hiddpg.host import make_host_env

    env = make_host_env("gym:" + ELBOW_ENV)
    assert env.obs_dim == 9 and env.goal_space.indices == (0,) and env.horizon == 100
    assert env.declared_skills(HDDPGConfig()).n_skills == 3
    made = env.make_one()
    model = made.unwrapped.model
    assert tuple(model.actuator(i).name for i in range(model.nu)) == ELBOW_MUSCLES
    low, high = model.jnt_range[0]
    assert low == ELBOW_GOAL[0][0] and abs(high - ELBOW_GOAL[0][1]) < 0.01
    obs, _ = made.reset(seed=0)
    assert obs[0] == np.float32(made.unwrapped.data.qpos[0])  # entry 0 is the angle
    made.close()

"""The Gymnasium adapter: env checker, registration, params as kwargs, action handling,
determinism, episode ends and info types."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import hiddpg
from hiddpg.envs.arm import FIELD_FRICTION
from hiddpg.envs.gym import HiddpgEnv, env_ids, register_envs

IDS = env_ids()


def test_every_task_is_registered():
    assert IDS == [
        "hiddpg/PuckTrajectory1-v0", "hiddpg/PuckTrajectory2-v0", "hiddpg/PuckTrajectory3-v0",
        "hiddpg/PuckObstacle-v0", "hiddpg/ArmReach-v0", "hiddpg/ArmObstacle-v0",
    ]
    for env_id in IDS:
        assert env_id in gym.registry
        assert gym.spec(env_id).max_episode_steps is None  # the core ends episodes itself


@pytest.mark.parametrize("env_id", IDS)
def test_check_env_passes_without_warnings(env_id):
    env = gym.make(env_id, render_mode="rgb_array")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped)
    env.close()


def test_register_is_idempotent_and_module_prefix_works():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        register_envs()
        register_envs()
    env = gym.make("hiddpg:hiddpg/ArmReach-v0")
    assert isinstance(env.unwrapped, HiddpgEnv)
    assert hiddpg.__version__


def test_spaces():
    puck = gym.make("hiddpg/PuckTrajectory2-v0")
    arm = gym.make("hiddpg/ArmReach-v0")
    assert puck.action_space == gym.spaces.Box(-1.0, 1.0, (2,), np.float32)
    assert arm.action_space == gym.spaces.Box(0.0, 1.0, (6,), np.float32)
    assert puck.observation_space.shape == (4,) and arm.observation_space.shape == (6,)
    assert puck.observation_space.dtype == np.float32
    assert np.all(np.isfinite(arm.observation_space.high))
    assert arm.metadata["render_fps"] == 50 and puck.metadata["render_fps"] == 10


def test_kwargs_change_core_params():
    default = gym.make("hiddpg/ArmReach-v0").unwrapped
    cw = gym.make("hiddpg/ArmReach-v0", field="cw").unwrapped
    assert cw.params.field == "cw"
    np.testing.assert_allclose(cw.params.friction, FIELD_FRICTION["cw"])
    assert not np.allclose(cw.params.friction, default.params.friction)

    fast = gym.make("hiddpg/PuckTrajectory2-v0", dt=0.05)
    slow = gym.make("hiddpg/PuckTrajectory2-v0")
    assert fast.unwrapped.params.dt == pytest.approx(0.05)
    (x_fast, _), (x_slow, _) = fast.reset(seed=0), slow.reset(seed=0)
    np.testing.assert_array_equal(x_fast, x_slow)
    action = np.zeros(2, np.float32)
    # with zero force the position moves by dt * v: half as far with the smaller dt
    step_fast = fast.step(action)[0][:2] - x_fast[:2]
    step_slow = slow.step(action)[0][:2] - x_slow[:2]
    np.testing.assert_allclose(step_fast, 0.5 * step_slow, rtol=1e-5)


def test_unknown_kwarg_is_named():
    with pytest.raises(ValueError, match="bogus"):
        gym.make("hiddpg/PuckObstacle-v0", bogus=3)
    with pytest.raises(ValueError, match="field"):
        gym.make("hiddpg/ArmReach-v0", field="sideways")


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_action_raises(bad):
    env = gym.make("hiddpg/ArmObstacle-v0")
    env.reset(seed=0)
    action = np.full(6, 0.5, np.float32)
    action[2] = bad
    with pytest.raises(ValueError, match="action"):
        env.step(action)


def test_wrong_action_shape_raises():
    env = gym.make("hiddpg/PuckTrajectory1-v0")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="shape"):
        env.step(np.zeros(3, np.float32))
    with pytest.raises(ValueError, match="action"):
        env.step("left")


def test_out_of_box_actions_are_clipped():
    env = gym.make("hiddpg/PuckTrajectory1-v0")
    env.reset(seed=0)
    clipped = env.step(np.array([5.0, -7.0]))
    env.reset(seed=0)
    bound = env.step(np.array([1.0, -1.0], np.float32))
    np.testing.assert_array_equal(clipped[0], bound[0])
    assert clipped[1] == bound[1]

    arm = gym.make("hiddpg/ArmReach-v0")
    arm.reset(seed=0)
    a = arm.step(np.array([5.0, -1.0, 2.0, 0.3, -4.0, 0.7]))[0]
    arm.reset(seed=0)
    b = arm.step(np.array([1.0, 0.0, 1.0, 0.3, 0.0, 0.7], np.float32))[0]
    np.testing.assert_array_equal(a, b)


def _episode(env, seed, n=20):
    obs, _ = env.reset(seed=seed)
    rng = np.random.default_rng(0)
    out = [obs]
    for _ in range(n):
        out.append(env.step(rng.uniform(0, 1, 6).astype(np.float32))[0])
    return np.stack(out)


def test_same_seed_same_observations():
    env = gym.make("hiddpg/ArmReach-v0")
    first, again = _episode(env, 7), _episode(env, 7)
    np.testing.assert_array_equal(first, again)
    other = _episode(gym.make("hiddpg/ArmReach-v0"), 8)
    assert not np.allclose(first[0, 4:], other[0, 4:])  # another random target


def test_arm_reach_target_option():
    env = gym.make("hiddpg/ArmReach-v0")
    target = (1.2, 1.0)
    obs, _ = env.reset(seed=0, options={"target": target})
    np.testing.assert_allclose(obs[4:], target, rtol=1e-6)
    np.testing.assert_allclose(env.unwrapped.state.target, target, rtol=1e-6)


def test_episode_ends_come_from_the_core():
    env = gym.make("hiddpg/PuckTrajectory1-v0")
    env.reset(seed=0)
    flags = [env.step(np.zeros(2, np.float32))[2:4] for _ in range(30)]
    assert flags[-1] == (True, False) and not any(any(f) for f in flags[:-1])

    arm = gym.make("hiddpg/ArmReach-v0", max_steps=5)
    assert arm.unwrapped.max_steps == 5
    arm.reset(seed=0)
    flags = [arm.step(np.zeros(6, np.float32))[2:4] for _ in range(5)]
    assert flags[-1] == (False, True) and not any(any(f) for f in flags[:-1])


def test_info_is_numpy_and_python():
    env = gym.make("hiddpg/ArmObstacle-v0")
    env.reset(seed=0)
    _, reward, terminated, truncated, info = env.step(np.zeros(6, np.float32))
    assert type(reward) is float and type(terminated) is bool and type(truncated) is bool
    assert isinstance(info["collision"], bool) and isinstance(info["distance"], float)
    assert isinstance(info["hand"], np.ndarray) and info["hand"].shape == (2,)

    puck = gym.make("hiddpg/PuckTrajectory2-v0")
    puck.reset(seed=0)
    info = puck.step(np.zeros(2, np.float32))[4]
    assert isinstance(info["goals"], np.ndarray) and info["goals"].shape == (2, 2)


def test_render_rgb_array():
    env = gym.make("hiddpg/ArmObstacle-v0", render_mode="rgb_array")
    env.reset(seed=0)
    first = env.render()
    for _ in range(10):
        env.step(np.array([1, 0, 0, 0, 1, 0], np.float32))
    later = env.render()
    assert first.dtype == np.uint8 and first.ndim == 3 and first.shape[2] == 3
    assert first.shape == later.shape and not np.array_equal(first, later)
    with pytest.raises(ValueError, match="render_mode"):
        HiddpgEnv("ArmReach", render_mode="human")

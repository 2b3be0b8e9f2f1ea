"""A small box-constrained quadratic program, solved by projected Newton.

Used by :func:`hiddpg.control.ilqr.ilqr` for the action bounds: at every time step of the backward
pass the feed-forward action change solves ``min_k ½ k'Q_uu k + Q_u'k`` subject to
``low - ū_t <= k <= high - ū_t`` (Tassa, Mansard & Todorov 2014, "Control-limited differential
dynamic programming"; the method is Bertsekas 1982). Pure JAX: jittable and vmappable.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp


def masked_hessian(H: jax.Array, free: jax.Array) -> jax.Array:
    """``H`` restricted to the free block, identity on the clamped entries."""
    return jnp.where(free[:, None] & free[None, :], H, 0.0) + jnp.diag(~free).astype(H.dtype)


def _clamped(x: jax.Array, grad: jax.Array, lower: jax.Array, upper: jax.Array) -> jax.Array:
    """Entries on a bound whose gradient pushes outwards (they stay on it)."""
    return ((x <= lower) & (grad > 0.0)) | ((x >= upper) & (grad < 0.0))


def box_qp(
    H: jax.Array, g: jax.Array, lower: jax.Array, upper: jax.Array,
    iterations: int = 20, steps: int = 10, armijo: float = 0.1, tolerance: float = 1e-7,
) -> tuple[jax.Array, jax.Array]:
    """``min_x ½ x'Hx + g'x`` s.t. ``lower <= x <= upper`` by projected Newton (Bertsekas 1982,
    as in Tassa et al. 2014), started at ``clip(0, lower, upper)``.

    Each iteration fixes the clamped set (at a bound with the gradient pushing outwards), takes a
    Newton step on the free entries and a projected Armijo line search over ``steps`` halvings
    (sufficient-decrease factor ``armijo``); it stops after ``iterations``, when no step
    decreases the objective, or when the free gradient is below ``tolerance · (1 + max|g|)``.
    ``H`` must be positive definite. Returns ``(x, free)``: the minimiser and the mask of the
    entries not clamped at the solution.
    """
    def objective(x):
        return 0.5 * x @ H @ x + g @ x

    def body(carry):
        x, i, _ = carry
        grad = g + H @ x
        free = ~_clamped(x, grad, lower, upper)
        direction = -jnp.linalg.solve(masked_hessian(H, free), jnp.where(free, grad, 0.0))
        sizes = 0.5 ** jnp.arange(steps, dtype=x.dtype)
        trials = jnp.clip(x + sizes[:, None] * direction, lower, upper)
        gains = jax.vmap(objective)(trials) - objective(x)
        ok = gains <= armijo * (trials - x) @ grad
        found = jnp.any(ok) & (jnp.max(jnp.abs(direction)) > 0.0)
        x_new = jnp.where(found, trials[jnp.argmax(ok)], x)
        small = jnp.max(jnp.abs(jnp.where(free, grad, 0.0))) <= tolerance * (1.0 + jnp.abs(g).max())
        return x_new, i + 1, ~found | small

    x0 = jnp.clip(jnp.zeros_like(g), lower, upper)
    x, _, _ = jax.lax.while_loop(
        lambda c: (c[1] < iterations) & ~c[2], body, (x0, jnp.int32(0), jnp.bool_(False))
    )
    return x, ~_clamped(x, g + H @ x, lower, upper)

"""What a task's return is without learning: the floors a learning curve is read against.

:func:`floor_returns` plays a fixed policy on one of our tasks, every episode to its end, and
returns the mean and standard deviation of the environment return over ``episodes`` episodes:

* ``rest``: the zero action (on the arm: no muscle active, the arm stays where it starts);
* ``random``: an action drawn uniformly from the action box at every step.

A learned policy that scores below both has learned something worse than doing nothing.
The diagnosis pages (docs/diagnosis.md, diagnosis-arm.md) quote these numbers;
``tests/test_docs_diagnosis.py`` recomputes them.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from hiddpg.envs.registry import make

POLICIES = ("rest", "random")


def floor_returns(task: str, policy: str, episodes: int = 1000, seed: int = 0
                  ) -> tuple[float, float]:
    """Mean and standard deviation of ``policy``'s environment return on ``task``."""
    if policy not in POLICIES:
        raise ValueError(f"policy={policy!r} must be one of {POLICIES}")
    if episodes < 1:
        raise ValueError(f"episodes={episodes} must be >= 1")
    env, params = make(task)
    steps = env.max_steps(params)

    def act(key: jax.Array) -> jax.Array:
        if policy == "rest":
            return jnp.zeros(env.action_dim)
        return jax.random.uniform(key, (env.action_dim,), minval=env.action_low,
                                  maxval=env.action_high)

    def episode(key: jax.Array) -> jax.Array:
        key, k0 = jax.random.split(key)
        _, state = env.reset(k0, params)

        def step(carry, k):
            state, done, total = carry
            ka, ks = jax.random.split(k)
            out = env.step(ks, state, act(ka), params)
            total = total + jnp.where(done, 0.0, out.reward)
            return (out.state, done | out.terminated, total), None

        init = (state, jnp.array(False), jnp.array(0.0))
        (_, _, total), _ = jax.lax.scan(step, init, jax.random.split(key, steps))
        return total

    returns = jax.jit(jax.vmap(episode))(jax.random.split(jax.random.PRNGKey(seed), episodes))
    return float(returns.mean()), float(returns.std())

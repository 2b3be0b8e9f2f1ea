"""Exploration noise on an actor's normalised ([-1, 1]) output (paper Alg. 1, lines 4 and 7).

Two kinds, chosen by :class:`~hiddpg.configs.NoiseConfig` (a static Python object):

* ``"ou"`` — the discretised Ornstein–Uhlenbeck process of the paper,
  ``x ← x + θ (0 − x) + σ N(0, I)`` with ``θ = α = 0.05``; the state is reset to 0 at the start
  of every episode. Its stationary standard deviation is ``σ / sqrt(1 − (1 − θ)²)``.
* ``"gaussian"`` — i.i.d. ``σ N(0, I)`` [decision]; the state is carried but unused.

API (pure, ``jit``/``vmap``-safe)::

    ns = noise.init(cfg, action_dim)          # at the start of every episode
    ns, eps = noise.sample(cfg, ns, key, episode)  # every step; action = clip(μ(s) + eps, -1, 1)

``NoiseConfig.final_sigma`` / ``decay_episodes`` make σ fall linearly with the agent's episode
count (:func:`scale`); by default σ is constant.

[decision] marks a value of ours where the paper is silent; docs/deviations.md (each with the
paper's value and why) lists them.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
from flax import struct

from hiddpg.configs import NoiseConfig


@struct.dataclass
class NoiseState:
    """Attributes: x — the OU process's current value (zeros for Gaussian noise)."""

    x: jax.Array


def init(config: NoiseConfig, action_dim: int) -> NoiseState:
    """A fresh process at its mean 0 (call at every episode start: the paper resets it)."""
    del config
    return NoiseState(x=jnp.zeros((action_dim,), jnp.float32))


def scale(config: NoiseConfig, episode: jax.Array | int = 0) -> jax.Array | float:
    """The noise scale σ at ``episode``: ``sigma``, or linear to ``final_sigma`` if it decays."""
    if not config.decays:
        return config.sigma
    frac = jnp.minimum(jnp.asarray(episode, jnp.float32) / config.decay_episodes, 1.0)
    return config.sigma + (config.final_sigma - config.sigma) * frac


def sample(config: NoiseConfig, state: NoiseState, key: jax.Array,
           episode: jax.Array | int = 0) -> tuple[NoiseState, jax.Array]:
    """Advance the process one step and return ``(new_state, noise)`` (``episode`` sets σ when
    the config decays it)."""
    eps = jax.random.normal(key, state.x.shape, state.x.dtype)
    sigma = scale(config, episode)
    if config.kind == "gaussian":
        return state, sigma * eps
    x = state.x + config.theta * (0.0 - state.x) + sigma * eps
    return NoiseState(x=x), x


def stationary_std(config: NoiseConfig) -> float:
    """Standard deviation of the noise in the stationary regime (OU: ``σ / sqrt(1-(1-θ)²)``)."""
    if config.kind == "gaussian":
        return config.sigma
    if config.theta == 0:
        return float("inf")  # a random walk has no stationary regime
    return config.sigma / (1.0 - (1.0 - config.theta) ** 2) ** 0.5

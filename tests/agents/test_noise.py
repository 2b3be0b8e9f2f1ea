"""Exploration noise: OU statistics (stationary std, mean reversion, autocorrelation), Gaussian."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from hiddpg.agents import noise
from hiddpg.configs import NoiseConfig

OU = NoiseConfig(kind="ou", theta=0.05, sigma=0.1)  # the paper's puck values


def _run(cfg, steps, processes, dim=2, x0=0.0, seed=0):
    """(steps, processes, dim) samples of ``processes`` independent runs from x = x0."""

    def one(key):
        state = noise.init(cfg, dim)
        state = state.replace(x=state.x + x0)

        def step(s, k):
            s, eps = noise.sample(cfg, s, k)
            return s, eps

        return jax.lax.scan(step, state, jax.random.split(key, steps))[1]

    keys = jax.random.split(jax.random.PRNGKey(seed), processes)
    return np.asarray(jax.jit(jax.vmap(one, out_axes=1))(keys))


def test_init_is_zero_mean_state():
    state = noise.init(OU, 3)
    np.testing.assert_array_equal(state.x, np.zeros(3, np.float32))


def test_ou_stationary_std_matches_theory():
    xs = _run(OU, steps=300, processes=2000)[200:]  # 200 steps ≫ 1/θ = 20: stationary
    expected = 0.1 / np.sqrt(1 - 0.95**2)  # ≈ 0.320
    assert abs(noise.stationary_std(OU) - expected) < 1e-12
    np.testing.assert_allclose(xs.std(), expected, rtol=0.03)
    assert abs(xs.mean()) < 0.02


def test_ou_lag_one_autocorrelation_is_one_minus_theta():
    xs = _run(OU, steps=300, processes=1000)[200:]
    a, b = xs[:-1].ravel(), xs[1:].ravel()
    np.testing.assert_allclose(np.corrcoef(a, b)[0, 1], 0.95, atol=0.01)


def test_ou_reverts_to_zero_mean():
    no_noise = NoiseConfig(kind="ou", theta=0.05, sigma=0.0)
    xs = _run(no_noise, steps=40, processes=1, x0=1.0)
    np.testing.assert_allclose(xs[:, 0, 0], 0.95 ** np.arange(1, 41), rtol=1e-5)
    noisy = _run(OU, steps=40, processes=4000, x0=1.0)
    means = noisy.mean(axis=(1, 2))
    np.testing.assert_allclose(means[[4, 19, 39]], 0.95 ** np.array([5, 20, 40]), atol=0.01)


def test_gaussian_is_iid_with_std_sigma():
    cfg = NoiseConfig(kind="gaussian", sigma=0.2)
    xs = _run(cfg, steps=200, processes=500)
    np.testing.assert_allclose(xs.std(), 0.2, rtol=0.02)
    assert abs(np.corrcoef(xs[:-1].ravel(), xs[1:].ravel())[0, 1]) < 0.02
    assert noise.stationary_std(cfg) == 0.2
    state, _ = noise.sample(cfg, noise.init(cfg, 2), jax.random.PRNGKey(0))
    np.testing.assert_array_equal(state.x, jnp.zeros(2))  # no state to carry


def test_same_key_same_noise():
    a = _run(OU, steps=10, processes=3, seed=5)
    b = _run(OU, steps=10, processes=3, seed=5)
    np.testing.assert_array_equal(a, b)


def test_decaying_scale_is_linear_then_flat():
    cfg = NoiseConfig(kind="gaussian", sigma=0.3, final_sigma=0.1, decay_episodes=100)
    got = [float(noise.scale(cfg, e)) for e in (0, 50, 100, 400)]
    np.testing.assert_allclose(got, [0.3, 0.2, 0.1, 0.1], rtol=1e-6)
    assert noise.scale(NoiseConfig(sigma=0.3), 1000) == 0.3  # no decay unless asked


def test_decayed_noise_has_the_episodes_std():
    cfg = NoiseConfig(kind="gaussian", sigma=0.4, final_sigma=0.0, decay_episodes=4)
    keys = jax.random.split(jax.random.PRNGKey(1), 20000)
    draw = jax.vmap(lambda k, e: noise.sample(cfg, noise.init(cfg, 1), k, e)[1][0],
                    in_axes=(0, None))
    np.testing.assert_allclose(np.std(draw(keys, 1)), 0.3, rtol=0.03)
    assert np.all(np.asarray(draw(keys, 7)) == 0.0)


def test_bad_decay_is_named():
    with pytest.raises(ValueError, match="decay_episodes=0"):
        NoiseConfig(final_sigma=0.1, decay_episodes=0)
    with pytest.raises(ValueError, match="final_sigma=nan"):
        NoiseConfig(final_sigma=float("nan"))

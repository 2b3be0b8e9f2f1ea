"""The dynamics models (paper §II-C): the loss is the mean squared error of the rate ``ṡ``, the
low level's model learns ``ṡ`` of a linear system for ``Δt ≠ 1`` and predicts ``s + Δt ṡ``,
and the high level's model (``Δt = 1``) predicts the next segment's state."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from hiddpg.agents.model_grad import DynamicsModel, ModelState
from hiddpg.agents.networks import MLP

N, A_LOW, A_HIGH = 4, 2, 3  # state size; low action (force), high action (2 goal entries + T)
HIDDEN = (16, 16)


def _linear_system(seed, n_samples=128, dt=0.05):
    rng = np.random.default_rng(seed)
    A = 0.5 * rng.normal(size=(N, N))
    Bm = rng.normal(size=(N, A_LOW))
    s = rng.uniform(-1, 1, (n_samples, N))
    a = rng.uniform(-1, 1, (n_samples, A_LOW))
    s_dot = s @ A.T + a @ Bm.T
    f32 = lambda x: jnp.asarray(x, jnp.float32)  # noqa: E731
    return f32(s), f32(a), f32(s + dt * s_dot), f32(s_dot)


def _model_state(model: DynamicsModel, seed: int = 0) -> ModelState:
    """Like ``model.init``, with the hidden layers' fan-in init drawn by numpy."""
    rng = np.random.default_rng(seed)
    shapes = jax.eval_shape(model.init, jax.random.PRNGKey(0)).params

    def draw(sd):
        bound = 1.0 / np.sqrt(sd.shape[0])
        return jnp.asarray(rng.uniform(-bound, bound, sd.shape) if len(sd.shape) == 2
                           else np.zeros(sd.shape), jnp.float32)

    params = jax.tree_util.tree_map(draw, shapes)
    return model.set_learning_rate(ModelState(params, model.optimizer.init(params)), model.lr)


def _train(model: DynamicsModel, s, a, s2, steps=1500):
    state = _model_state(model)

    @jax.jit
    def run(state):
        return jax.lax.scan(lambda st, _: model.update(st, s, a, s2), state, None, steps)

    return state, *run(state)


def test_dynamics_model_loss_is_the_rate_mse():
    dt = 0.05
    s, a, s2, _ = _linear_system(0, 16, dt)
    model = DynamicsModel(N, A_LOW, HIDDEN, 1e-3, dt)
    params = _model_state(model, 1).params
    rate = jax.jit(MLP(HIDDEN, N).apply)(params, jnp.concatenate([s, a], -1))
    expected = np.mean(np.sum((np.asarray(rate) - np.asarray((s2 - s) / dt)) ** 2, -1))
    np.testing.assert_allclose(jax.jit(model.loss)(params, s, a, s2), expected, rtol=1e-5)
    np.testing.assert_allclose(jax.jit(model.predict)(params, s, a), s + dt * rate,
                               rtol=1e-6, atol=1e-7)


def test_dynamics_model_learns_the_rate_of_a_linear_system_for_dt_not_one():
    dt = 0.05
    s, a, s2, s_dot = _linear_system(0, dt=dt)
    model = DynamicsModel(N, A_LOW, HIDDEN, 3e-3, dt)
    init, trained, losses = _train(model, s, a, s2)
    losses = np.asarray(losses)
    assert losses[-1] < 0.01 * losses[0]  # the loss falls by two orders of magnitude
    assert np.all(np.diff(losses[::100]) < 0)  # and keeps falling
    # the network output is ṡ (not s' - s = Δt ṡ) ...
    rate = model.net.apply(trained.params, jnp.concatenate([s, a], -1))
    rel = lambda x, y: float(jnp.linalg.norm(x - y) / jnp.linalg.norm(y))  # noqa: E731
    assert rel(rate, s_dot) < 0.05
    assert rel(rate, dt * s_dot) > 10  # far from the Δt-scaled target
    # ... and the prediction is s'
    pred = model.predict(trained.params, s, a)
    assert rel(pred - s, s2 - s) < 0.05
    np.testing.assert_allclose(pred, s2, atol=0.05 * dt * float(jnp.abs(s_dot).max()))
    # the untrained model was far off
    assert rel(model.predict(init.params, s, a) - s, s2 - s) > 0.5


def test_high_level_model_predicts_the_next_state_with_time_scale_one():
    """M_H predicts s_{i+1} from (s_i, g, T) via the change s_{i+1} - s_i (Δt = 1)."""
    s, a, _, _ = _linear_system(1)
    a3 = jnp.concatenate([a, a[:, :1] * a[:, 1:]], -1)  # 3 inputs: goal entries and T
    W = jnp.asarray(np.random.default_rng(2).normal(size=(N, A_HIGH)), jnp.float32)
    s2 = 0.9 * s + a3 @ W.T
    model = DynamicsModel(N, A_HIGH, HIDDEN, 3e-3, 1.0)
    _, trained, losses = _train(model, s, a3, s2, steps=2000)
    assert float(losses[-1]) < 0.02 * float(losses[0])
    pred = model.predict(trained.params, s, a3)
    assert float(jnp.linalg.norm(pred - s2) / jnp.linalg.norm(s2 - s)) < 0.1

"""The model-based action gradient (paper §II-C, eqs. 6-7; spec §3) and the dynamics models.

``model_gradient(value, predict, a)`` must be ``∂V(ŝ')/∂ŝ' · ∂ŝ'/∂a``. It is checked, for both
levels' forms, against three independent computations written here from the raw flax modules
(not through :class:`Level`): ``jax.grad`` of the composed function, the explicit chain-rule
product with ``jax.jacobian``, and central finite differences in float64. Then: how
:meth:`Level.extra_dq_da` enters the actor update (off for ``λ = 0``, linear in ``λ``), and
that :class:`DynamicsModel` learns ``ṡ`` of a linear system for ``Δt ≠ 1``.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from hiddpg.agents import buffer
from hiddpg.agents.level import Level
from hiddpg.agents.model_grad import DynamicsModel, batched_model_gradient, model_gradient
from hiddpg.agents.networks import MLP, Actor, Critic
from hiddpg.configs import LevelConfig

N, A_LOW, A_HIGH = 4, 2, 3  # state size; low action (force), high action (2 goal entries + T)
HIDDEN = (16, 16)
DT = 0.1  # the low level's Δt (≠ 1 so that the Δt scaling is visible)
B = 6


def _level(kind: str, model_weight: float = 1.0, use_model: bool = True) -> Level:
    cfg = LevelConfig(hidden=HIDDEN, lr=1e-3, gamma=0.9, tau=0.1, batch_size=8, buffer_size=32)
    if kind == "low":  # actor input [s, g]; ŝ' = s + Δt M(s, a)
        return Level(cfg, N, N, A_LOW, DT, model_weight, use_model)
    return Level(cfg, N, 0, A_HIGH, 1.0, model_weight, use_model)  # ŝ' = s + M(s, (g, T))


def _bump(tree, key, scale=0.3):
    """Add noise to every parameter: the DDPG init makes Q and μ nearly constant (final layers
    ±3e-3), which would make every gradient tiny; here all three networks are non-trivial."""
    leaves, treedef = jax.tree_util.tree_flatten(tree)
    keys = jax.random.split(key, len(leaves))
    noisy = [x + scale * jax.random.normal(k, x.shape, x.dtype) for x, k in zip(leaves, keys)]
    return jax.tree_util.tree_unflatten(treedef, noisy)


def _setup(kind: str, seed: int = 0, **level_kw):
    """A level with random non-trivial actor, critic and model, and a batch of actor inputs."""
    level = _level(kind, **level_kw)
    k = jax.random.split(jax.random.PRNGKey(seed), 6)
    state = level.init(k[0])
    block = state.block.replace(actor=_bump(state.block.actor, k[1]),
                                critic=_bump(state.block.critic, k[2]))
    state = state.replace(block=block, model=state.model.replace(params=_bump(
        state.model.params, k[3])))
    inputs = jax.random.normal(k[4], (B, level.state_dim + level.context_dim))
    actions = jax.random.uniform(k[5], (B, level.action_dim), minval=-0.9, maxval=0.9)
    return level, state, inputs, actions


def _raw(level: Level, state, dtype=jnp.float32):
    """``predict(inp, a)`` and ``value(inp, x)`` written from the flax modules and the paper's
    formulas: ŝ' = s + Δt·M([s, a]) and V(x) = Q([x, c], μ([x, c]))."""
    n, hidden = level.state_dim, HIDDEN
    cast = lambda t: jax.tree_util.tree_map(lambda x: x.astype(dtype), t)  # noqa: E731
    actor, critic, model = (cast(state.block.actor), cast(state.block.critic),
                            cast(state.model.params))
    net, mu, q = MLP(hidden, n), Actor(hidden, level.action_dim), Critic(hidden)

    def rate(inp, a):  # the network output: ṡ for the low level, s_{i+1} - s_i for the high
        return net.apply(model, jnp.concatenate([inp[:n], a]))

    def predict(inp, a):
        return inp[:n] + level.time_scale * rate(inp, a)

    def value(inp, x):
        xc = jnp.concatenate([x, inp[n:]])
        return q.apply(critic, xc, mu.apply(actor, xc))

    return predict, value, rate


@pytest.fixture
def x64():
    """float64 for the finite differences; the previous setting is restored afterwards."""
    previous = bool(jax.config.read("jax_enable_x64"))
    jax.config.update("jax_enable_x64", True)
    try:
        yield
    finally:
        jax.config.update("jax_enable_x64", previous)


# -- the gradient itself ------------------------------------------------------------------------
def test_model_gradient_on_an_analytic_function():
    """V(x) = Σ sin(x) w, ŝ'(a) = W a + b: ∂V/∂a = Wᵀ (w ⊙ cos(W a + b))."""
    k = jax.random.split(jax.random.PRNGKey(3), 4)
    W, b = jax.random.normal(k[0], (N, 3)), jax.random.normal(k[1], (N,))
    w, a = jax.random.normal(k[2], (N,)), jax.random.normal(k[3], (3,))
    got = model_gradient(lambda x: jnp.sum(jnp.sin(x) * w), lambda a_: W @ a_ + b, a)
    assert got.shape == a.shape
    np.testing.assert_allclose(got, W.T @ (w * jnp.cos(W @ a + b)), rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("kind", ["low", "high"])
def test_model_gradient_equals_grad_of_the_composition_and_the_chain_rule(kind):
    level, state, inputs, actions = _setup(kind)
    predict, value, rate = _raw(level, state)

    @jax.jit
    def gradients(inputs, actions):
        # what the library computes: per sample, and batched inside Level.extra_dq_da (λ = 1)
        single = jax.vmap(lambda inp, a: model_gradient(
            lambda x: value(inp, x), lambda a_: predict(inp, a_), a))(inputs, actions)
        batched = batched_model_gradient(value, predict, inputs, actions)
        extra = level.extra_dq_da(state.block, state.model)(inputs, actions)

        # (a) jax.grad of a -> V(ŝ'(a))
        composed = jax.vmap(jax.grad(lambda inp, a: value(inp, predict(inp, a)), argnums=1))(
            inputs, actions)

        # (b) (∂V/∂ŝ')ᵀ J_predict(a), with J_predict = Δt ∂M/∂a (eq. 6; Δt = 1 on the high level)
        def chain_one(inp, a):
            dv_ds = jax.grad(lambda x: value(inp, x))(predict(inp, a))
            jac = jax.jacobian(lambda a_: predict(inp, a_))(a)
            jac_rate = jax.jacobian(lambda a_: rate(inp, a_))(a)
            return dv_ds @ jac, jac, jac_rate

        chain, jac, jac_rate = jax.vmap(chain_one)(inputs, actions)
        return single, batched, extra, composed, chain, jac, jac_rate

    single, batched, extra, composed, chain, jac, jac_rate = gradients(inputs, actions)
    assert jac.shape == (B, N, level.action_dim)
    np.testing.assert_allclose(jac, level.time_scale * jac_rate, rtol=1e-5, atol=1e-7)
    assert float(jnp.abs(composed).max()) > 1e-2  # a non-trivial gradient is compared
    for got in (single, batched, extra):
        assert got.shape == (B, level.action_dim)
        np.testing.assert_allclose(got, composed, rtol=1e-5, atol=1e-6)
        np.testing.assert_allclose(got, chain, rtol=1e-4, atol=1e-6)


def test_the_low_level_jacobian_scales_with_dt():
    """Same network, Δt and 2Δt: ∂ŝ'/∂a doubles (the paper's ``Δt ∂ṡ/∂a``)."""
    level, state, inputs, actions = _setup("low")
    m1 = DynamicsModel(N, A_LOW, HIDDEN, 1e-3, DT)
    m2 = DynamicsModel(N, A_LOW, HIDDEN, 1e-3, 2 * DT)
    p, s, a = state.model.params, inputs[0, :N], actions[0]
    j1 = jax.jacobian(lambda a_: m1.predict(p, s, a_))(a)
    j2 = jax.jacobian(lambda a_: m2.predict(p, s, a_))(a)
    assert float(jnp.abs(j1).max()) > 1e-3
    np.testing.assert_allclose(j2, 2.0 * j1, rtol=1e-6, atol=1e-8)


@pytest.mark.parametrize("kind", ["low", "high"])
def test_model_gradient_matches_central_finite_differences_in_float64(kind, x64):
    level, state, inputs, actions = _setup(kind)
    predict, value, _ = _raw(level, state, jnp.float64)
    inputs, actions = inputs.astype(jnp.float64), actions.astype(jnp.float64)
    eps = 1e-6

    @jax.jit
    def check(inp, a):
        f = lambda a_: value(inp, predict(inp, a_))  # noqa: E731
        got = model_gradient(lambda x: value(inp, x), lambda a_: predict(inp, a_), a)
        eye = jnp.eye(a.shape[0], dtype=jnp.float64)
        fd = jax.vmap(lambda e: (f(a + eps * e) - f(a - eps * e)) / (2 * eps))(eye)
        return got, fd

    got, fd = jax.vmap(check)(inputs, actions)
    assert got.dtype == jnp.float64 and got.shape == (B, level.action_dim)
    assert float(jnp.abs(got).max()) > 1e-2
    np.testing.assert_allclose(got, fd, rtol=1e-6, atol=1e-9)


# -- how the term enters the actor update ---------------------------------------------------
def _grads_equal(a, b) -> bool:
    same = jax.tree_util.tree_map(lambda x, y: np.array_equal(np.asarray(x), np.asarray(y)), a, b)
    return jax.tree_util.tree_all(same)


@pytest.mark.parametrize("kind", ["low", "high"])
def test_policy_gradient_is_linear_in_the_model_weight(kind):
    """∇θ J(λ) = ∇θ J_DDPG + λ · (pullback of the model term through μ)."""
    grads = {}
    for lam in (0.0, 1.0, 2.0):
        level, state, inputs, _ = _setup(kind, model_weight=lam)
        extra = level.extra_dq_da(state.block, state.model)
        if lam == 0.0:
            zero = extra(inputs, level.act(state, inputs[:, :N], inputs[:, N:]))
            np.testing.assert_array_equal(zero, 0.0)  # λ = 0: the term vanishes
            extra = None  # and Level.update passes none at all (checked below)
        grads[lam], _ = level.block.policy_gradient(state.block, inputs, extra)

    # the model term's own pullback, from the raw modules: -mean_b (term_b · ∂μ(x_b)/∂θ)
    level, state, inputs, _ = _setup(kind)
    predict, value, _ = _raw(level, state)
    mu = Actor(HIDDEN, level.action_dim)
    a = mu.apply(state.block.actor, inputs)
    term = jax.vmap(jax.grad(lambda inp, a_: value(inp, predict(inp, a_)), argnums=1))(inputs, a)
    model_part = jax.grad(
        lambda p: -jnp.mean(jnp.sum(jax.lax.stop_gradient(term) * mu.apply(p, inputs), -1))
    )(state.block.actor)

    flat = lambda t: np.concatenate([np.ravel(x) for x in jax.tree_util.tree_leaves(t)])  # noqa
    g0, g1, g2, gm = flat(grads[0.0]), flat(grads[1.0]), flat(grads[2.0]), flat(model_part)
    assert np.abs(gm).max() > 1e-3 * np.abs(g0).max()  # the term is not negligible
    np.testing.assert_allclose(g1, g0 + gm, rtol=1e-4, atol=1e-6)
    np.testing.assert_allclose(g2, g0 + 2.0 * gm, rtol=1e-4, atol=1e-6)
    np.testing.assert_allclose(g2 - g0, 2.0 * (g1 - g0), rtol=1e-3, atol=1e-6)


def _filled(level: Level, state, key):
    """The level's buffer filled with random transitions."""
    k = jax.random.split(key, 5)
    n, c, na, cap = level.state_dim, level.context_dim, level.action_dim, 32
    tr = {"s": jax.random.normal(k[0], (cap, n)), "c": jax.random.normal(k[1], (cap, c)),
          "a": jax.random.uniform(k[2], (cap, na), minval=-1, maxval=1),
          "r": jax.random.normal(k[3], (cap,)), "s2": jax.random.normal(k[4], (cap, n)),
          "terminated": jnp.zeros((cap,), bool)}
    add = lambda buf, t: (buffer.add(buf, t), None)  # noqa: E731
    buf, _ = jax.jit(lambda b: jax.lax.scan(add, b, tr))(state.buffer)
    assert int(buf.size) == cap
    return state.replace(buffer=buf)


@pytest.mark.parametrize("kind", ["low", "high"])
def test_level_update_with_model_weight_zero_is_the_plain_ddpg_update(kind):
    level, state, _, _ = _setup(kind, model_weight=0.0)
    state = _filled(level, state, jax.random.PRNGKey(7))
    key = jax.random.PRNGKey(11)
    new, metrics = jax.jit(level.update)(state, key)

    # the plain DDPG step of the block on the same minibatch
    tr = buffer.sample(state.buffer, key, level.config.batch_size)
    batch = {"obs": jnp.concatenate([tr["s"], tr["c"]], -1), "action": tr["a"],
             "reward": tr["r"], "next_obs": jnp.concatenate([tr["s2"], tr["c"]], -1),
             "terminated": tr["terminated"]}
    plain, plain_m = jax.jit(level.block.update)(state.block, batch)
    for name in ("actor", "critic", "target_actor", "target_critic"):
        a, b = getattr(new.block, name), getattr(plain, name)
        jax.tree_util.tree_map(lambda x, y: np.testing.assert_allclose(x, y, rtol=1e-6,
                                                                       atol=1e-8), a, b)
    np.testing.assert_allclose(metrics["critic_loss"], plain_m["critic_loss"], rtol=1e-6)
    np.testing.assert_allclose(metrics["actor_loss"], plain_m["actor_loss"], rtol=1e-6)
    # the model still learns (use_model) and its loss is the loss before the step
    before = level.model.loss(state.model.params, tr["s"], tr["a"], tr["s2"])
    np.testing.assert_allclose(metrics["model_loss"], before, rtol=1e-6)
    assert not _grads_equal(new.model.params, state.model.params)

    # λ = 1 changes the actor step only: the critic step is the same
    level1 = _level(kind, model_weight=1.0)
    new1, _ = jax.jit(level1.update)(state, key)
    jax.tree_util.tree_map(lambda x, y: np.testing.assert_allclose(x, y, rtol=1e-6, atol=1e-8),
                           new1.block.critic, new.block.critic)
    assert not _grads_equal(new1.block.actor, new.block.actor)

    # without the model (HI-DDPG-wo-model) the model is frozen and reports no loss
    level_wo = _level(kind, model_weight=0.0, use_model=False)
    new_wo, m_wo = jax.jit(level_wo.update)(state, key)
    assert _grads_equal(new_wo.model, state.model)
    assert float(m_wo["model_loss"]) == 0.0
    assert _grads_equal(new_wo.block, new.block)


# -- the dynamics model ---------------------------------------------------------------------
def _linear_system(key, n_samples=128, dt=0.05):
    k = jax.random.split(key, 4)
    A = 0.5 * jax.random.normal(k[0], (N, N))
    Bm = jax.random.normal(k[1], (N, A_LOW))
    s = jax.random.uniform(k[2], (n_samples, N), minval=-1, maxval=1)
    a = jax.random.uniform(k[3], (n_samples, A_LOW), minval=-1, maxval=1)
    s_dot = s @ A.T + a @ Bm.T
    return s, a, s + dt * s_dot, s_dot


def _train(model: DynamicsModel, s, a, s2, steps=1500):
    state = model.init(jax.random.PRNGKey(0))

    @jax.jit
    def run(state):
        return jax.lax.scan(lambda st, _: model.update(st, s, a, s2), state, None, steps)

    return state, *run(state)


def test_dynamics_model_loss_is_the_rate_mse():
    dt = 0.05
    s, a, s2, _ = _linear_system(jax.random.PRNGKey(0), 16, dt)
    model = DynamicsModel(N, A_LOW, HIDDEN, 1e-3, dt)
    params = model.init(jax.random.PRNGKey(1)).params
    rate = MLP(HIDDEN, N).apply(params, jnp.concatenate([s, a], -1))
    expected = np.mean(np.sum((np.asarray(rate) - np.asarray((s2 - s) / dt)) ** 2, -1))
    np.testing.assert_allclose(model.loss(params, s, a, s2), expected, rtol=1e-5)
    np.testing.assert_allclose(model.predict(params, s, a), s + dt * rate, rtol=1e-6, atol=1e-7)


def test_dynamics_model_learns_the_rate_of_a_linear_system_for_dt_not_one():
    dt = 0.05
    s, a, s2, s_dot = _linear_system(jax.random.PRNGKey(0), dt=dt)
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
    s, a, _, _ = _linear_system(jax.random.PRNGKey(1))
    a3 = jnp.concatenate([a, a[:, :1] * a[:, 1:]], -1)  # 3 inputs: goal entries and T
    W = jax.random.normal(jax.random.PRNGKey(2), (N, A_HIGH))
    s2 = 0.9 * s + a3 @ W.T
    model = DynamicsModel(N, A_HIGH, HIDDEN, 3e-3, 1.0)
    _, trained, losses = _train(model, s, a3, s2, steps=2000)
    assert float(losses[-1]) < 0.02 * float(losses[0])
    pred = model.predict(trained.params, s, a3)
    assert float(jnp.linalg.norm(pred - s2) / jnp.linalg.norm(s2 - s)) < 0.1

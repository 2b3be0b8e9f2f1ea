"""The model-based action gradient (paper §II-C, eqs. 6-7; spec §3).

``model_gradient(value, predict, a)`` must be ``∂V(ŝ')/∂ŝ' · ∂ŝ'/∂a``. It is checked, for both
levels' forms, against three independent computations written here from the raw flax modules
(not through :class:`Level`): ``jax.grad`` of the composed function, the explicit chain-rule
product with ``jax.jacobian``, and central finite differences in float64. Then: how
:meth:`Level.extra_dq_da` enters the actor update (off for ``λ = 0``, linear in ``λ``). The
dynamics models are tested in ``test_dynamics_model.py``, the terminal mask in
``test_model_mask.py``.
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from hiddpg.agents import buffer
from hiddpg.agents.block import BlockState
from hiddpg.agents.level import Level, LevelState, update_keys
from hiddpg.agents.model_grad import (
    DynamicsModel,
    ModelState,
    batched_model_gradient,
    model_gradient,
)
from hiddpg.agents.networks import MLP, Actor, Critic
from hiddpg.agents.transition import Transition, example
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


def _random_params(shapes, rng: np.random.Generator):
    """Random parameters shaped like ``shapes`` (from ``jax.eval_shape``): kernels
    ``N(0, 1/fan_in)``, biases ``N(0, 0.1²)``. The DDPG init would make Q and μ nearly constant
    (final layers ±3e-3) and every gradient tiny; these networks are non-trivial. numpy draws
    them because ``jax.random`` inside ``jit`` is slow to compile (each call ~0.5 s on CPU)."""

    def draw(sd):
        std = 1.0 / np.sqrt(sd.shape[0]) if len(sd.shape) == 2 else 0.1
        return jnp.asarray(rng.normal(0.0, std, sd.shape), jnp.float32)

    return jax.tree_util.tree_map(draw, shapes)


@functools.cache
def _random_state(kind: str, seed: int = 0):
    """A level state with random actor, critic and model (the state does not depend on λ) and
    a batch of actor inputs and unit actions. Built like :meth:`Level.init`, without jax.random.
    """
    level, rng = _level(kind), np.random.default_rng(seed)
    shapes = jax.eval_shape(level.init, jax.random.PRNGKey(0))
    block, model, lr = level.block, level.model, level.config.lr
    actor, critic = (_random_params(shapes.block.actor, rng),
                     _random_params(shapes.block.critic, rng))
    block_state = block.set_learning_rates(
        BlockState(actor, critic, actor, critic, block.actor_tx.init(actor),
                   block.critic_tx.init(critic)), lr, lr)
    params = _random_params(shapes.model.params, rng)
    model_state = model.set_learning_rate(ModelState(params, model.optimizer.init(params)), lr)
    tr = example(level.state_dim, level.action_dim, level.context_dim)
    state = LevelState(block_state, model_state, buffer.init(tr, level.config.buffer_size))
    assert jax.tree_util.tree_structure(state) == jax.tree_util.tree_structure(shapes)
    inputs = jnp.asarray(rng.normal(size=(B, level.state_dim + level.context_dim)), jnp.float32)
    actions = jnp.asarray(rng.uniform(-0.9, 0.9, (B, level.action_dim)), jnp.float32)
    return state, inputs, actions


def _setup(kind: str, seed: int = 0, **level_kw):
    return (_level(kind, **level_kw), *_random_state(kind, seed))


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
    for kind in ("low", "high"):  # the shared random states are built (cached) in float32
        _random_state(kind, 0)
    previous = bool(jax.config.read("jax_enable_x64"))
    jax.config.update("jax_enable_x64", True)
    try:
        yield
    finally:
        jax.config.update("jax_enable_x64", previous)


# -- the gradient itself ------------------------------------------------------------------------
def test_model_gradient_on_an_analytic_function():
    """V(x) = Σ sin(x) w, ŝ'(a) = W a + b: ∂V/∂a = Wᵀ (w ⊙ cos(W a + b))."""
    rng = np.random.default_rng(3)
    W, b, w, a = (jnp.asarray(rng.normal(size=shape), jnp.float32)
                  for shape in ((N, 3), (N,), (N,), (3,)))
    got = model_gradient(lambda x: jnp.sum(jnp.sin(x) * w), lambda a_: W @ a_ + b, a)
    assert got.shape == a.shape
    np.testing.assert_allclose(got, W.T @ (w * jnp.cos(W @ a + b)), rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("kind", ["low", "high"])
def test_model_gradient_equals_grad_of_the_composition_and_the_chain_rule(kind):
    level, state, inputs, actions = _setup(kind)

    @jax.jit
    def gradients(state, inputs, actions):
        predict, value, rate = _raw(level, state)
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

    single, batched, extra, composed, chain, jac, jac_rate = gradients(state, inputs, actions)
    assert jac.shape == (B, N, level.action_dim)
    np.testing.assert_allclose(jac, level.time_scale * jac_rate, rtol=1e-5, atol=1e-7)
    assert float(jnp.abs(composed).max()) > 1e-3  # a non-trivial gradient is compared
    for got in (single, batched, extra):
        assert got.shape == (B, level.action_dim)
        np.testing.assert_allclose(got, composed, rtol=1e-5, atol=1e-6)
        np.testing.assert_allclose(got, chain, rtol=1e-4, atol=1e-6)


def test_the_low_level_jacobian_scales_with_dt():
    """Same network, Δt and 2Δt: ∂ŝ'/∂a doubles (the paper's ``Δt ∂ṡ/∂a``)."""
    _, state, inputs, actions = _setup("low")
    m1 = DynamicsModel(N, A_LOW, HIDDEN, 1e-3, DT)
    m2 = DynamicsModel(N, A_LOW, HIDDEN, 1e-3, 2 * DT)

    @jax.jit
    def jacobians(p, s, a):
        return (jax.jacobian(lambda a_: m1.predict(p, s, a_))(a),
                jax.jacobian(lambda a_: m2.predict(p, s, a_))(a))

    j1, j2 = jacobians(state.model.params, inputs[0, :N], actions[0])
    assert float(jnp.abs(j1).max()) > 1e-3
    np.testing.assert_allclose(j2, 2.0 * j1, rtol=1e-6, atol=1e-8)


@pytest.mark.parametrize("kind", ["low", "high"])
def test_model_gradient_matches_central_finite_differences_in_float64(kind, x64):
    level, state, inputs, actions = _setup(kind)
    eps = 1e-6

    @jax.jit
    def check(state, inputs, actions):
        predict, value, _ = _raw(level, state, jnp.float64)

        def one(inp, a):
            f = lambda a_: value(inp, predict(inp, a_))  # noqa: E731
            got = model_gradient(lambda x: value(inp, x), lambda a_: predict(inp, a_), a)
            eye = jnp.eye(a.shape[0], dtype=jnp.float64)
            fd = jax.vmap(lambda e: (f(a + eps * e) - f(a - eps * e)) / (2 * eps))(eye)
            return got, fd

        return jax.vmap(one)(inputs.astype(jnp.float64), actions.astype(jnp.float64))

    got, fd = check(state, inputs, actions)
    assert got.dtype == jnp.float64 and got.shape == (B, level.action_dim)
    assert float(jnp.abs(got).max()) > 1e-3
    np.testing.assert_allclose(got, fd, rtol=1e-6, atol=1e-9)


# -- how the term enters the actor update ---------------------------------------------------
def _trees_equal(a, b) -> bool:
    same = jax.tree_util.tree_map(lambda x, y: np.array_equal(np.asarray(x), np.asarray(y)), a, b)
    return jax.tree_util.tree_all(same)


def _trees_close(a, b, rtol=1e-6, atol=1e-8) -> None:
    jax.tree_util.tree_map(lambda x, y: np.testing.assert_allclose(x, y, rtol=rtol, atol=atol),
                           a, b)


def _flat(tree) -> np.ndarray:
    return np.concatenate([np.ravel(x) for x in jax.tree_util.tree_leaves(tree)])


@pytest.mark.parametrize("kind", ["low", "high"])
def test_policy_gradient_is_linear_in_the_model_weight(kind):
    """∇θ J(λ) = ∇θ J_DDPG + λ · (pullback of the model term through μ); λ = 0 adds nothing."""
    levels = {lam: _level(kind, model_weight=lam) for lam in (0.0, 1.0, 2.0)}
    _, state, inputs, _ = _setup(kind)

    @jax.jit
    def gradients(state, inputs):
        out = {}
        a = levels[0.0].act(state, inputs[:, :N], inputs[:, N:])
        zero = levels[0.0].extra_dq_da(state.block, state.model)(inputs, a)
        for lam, level in levels.items():
            # Level.update passes no extra term at all for λ = 0 (checked below)
            extra = level.extra_dq_da(state.block, state.model) if lam > 0 else None
            out[f"lambda={lam}"], _ = level.block.policy_gradient(state.block, inputs, extra)
        # the model term's own pullback, from the raw modules: -mean_b (term_b · ∂μ(x_b)/∂θ)
        predict, value, _ = _raw(levels[1.0], state)
        mu = Actor(HIDDEN, levels[1.0].action_dim)
        a = mu.apply(state.block.actor, inputs)
        term = jax.vmap(jax.grad(lambda inp, a_: value(inp, predict(inp, a_)), argnums=1))(
            inputs, a)
        out["model"] = jax.grad(
            lambda p: -jnp.mean(jnp.sum(jax.lax.stop_gradient(term) * mu.apply(p, inputs), -1))
        )(state.block.actor)
        return out, zero

    grads, zero = gradients(state, inputs)
    np.testing.assert_array_equal(zero, 0.0)  # λ = 0: extra_dq_da is zero
    g0, g1, g2, gm = (_flat(grads[k]) for k in ("lambda=0.0", "lambda=1.0", "lambda=2.0",
                                                  "model"))
    assert np.abs(gm).max() > 1e-3 * np.abs(g0).max()  # the term is not negligible
    np.testing.assert_allclose(g1, g0 + gm, rtol=1e-4, atol=1e-6)
    np.testing.assert_allclose(g2, g0 + 2.0 * gm, rtol=1e-4, atol=1e-6)
    np.testing.assert_allclose(g2 - g0, 2.0 * (g1 - g0), rtol=1e-3, atol=1e-6)


@pytest.mark.parametrize("kind", ["low", "high"])
def test_level_update_with_model_weight_zero_is_the_plain_ddpg_update(kind):
    level0 = _level(kind, model_weight=0.0)
    level1 = _level(kind, model_weight=1.0)
    level_wo = _level(kind, model_weight=0.0, use_model=False)
    _, state, _, _ = _setup(kind)
    n, c, na, cap = level0.state_dim, level0.context_dim, level0.action_dim, 32

    rng = np.random.default_rng(5)
    tr = Transition(obs=rng.normal(size=(cap, n)), context=rng.normal(size=(cap, c)),
                    action=rng.uniform(-1, 1, (cap, na)), reward=rng.normal(size=cap),
                    next_obs=rng.normal(size=(cap, n)), terminated=np.arange(cap) % 5 == 0)
    tr = jax.tree.map(lambda v: jnp.asarray(v, jnp.float32 if v.dtype == np.float64
                                            else v.dtype), tr)
    episode = jnp.zeros((), jnp.int32)

    @jax.jit
    def run(state, tr, key):
        buf, _ = jax.lax.scan(lambda b, t: (buffer.add(b, t), None), state.buffer, tr)
        state = state.replace(buffer=buf)
        # the plain DDPG step of the block on the minibatch Level.update draws
        batch = buffer.sample(buf, update_keys(key)["sample"], level0.config.batch_size)
        plain = level0.block.update(state.block, batch)
        before = level0.model.loss(state.model.params, batch.obs, batch.action, batch.next_obs)
        return (state, level0.update(state, key, episode=episode), plain, before,
                level1.update(state, key, episode=episode),
                level_wo.update(state, key, episode=episode))

    state, (new, m), (plain, plain_m), before, (new1, _), (new_wo, m_wo) = run(
        state, tr, jax.random.PRNGKey(7))
    assert int(state.buffer.size) == cap
    for name in ("actor", "critic", "target_actor", "target_critic"):
        _trees_close(getattr(new.block, name), getattr(plain, name))
    assert not _trees_equal(new.block.actor, state.block.actor)
    np.testing.assert_allclose(m["critic_loss"], plain_m["critic_loss"], rtol=1e-6)
    np.testing.assert_allclose(m["actor_loss"], plain_m["actor_loss"], rtol=1e-6)
    # the model still learns (use_model) and reports its loss before the step
    np.testing.assert_allclose(m["model_loss"], before, rtol=1e-6)
    assert float(before) > 0 and not _trees_equal(new.model.params, state.model.params)

    # λ = 1 changes the actor step only: the critic step is the same, the actor's is not
    _trees_close(new1.block.critic, new.block.critic)
    _trees_close(new1.model, new.model)
    assert not _trees_equal(new1.block.actor, new.block.actor)

    # without the model (HI-DDPG-wo-model) the model is frozen and reports no loss
    assert _trees_equal(new_wo.model, state.model)
    assert float(m_wo["model_loss"]) == 0.0
    _trees_close(new_wo.block, new.block)

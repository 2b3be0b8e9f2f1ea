"""The shared DDPG block: critic target and loss (eq. 3), policy gradient (eq. 2) with the extra
``dq_da`` seam (eqs. 6-7), Polyak averaging, learning rates, jit/vmap."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from hiddpg.agents.block import BlockState, DDPGBlock
from hiddpg.agents.transition import Transition

OBS, ACT, B = 3, 2, 32


def _block(**kw):
    args = dict(obs_dim=OBS, action_dim=ACT, hidden=(32, 32), actor_lr=1e-3, critic_lr=1e-2,
                gamma=0.9, tau=0.1)
    return DDPGBlock(**{**args, **kw})


def _batch(seed=0, terminated=None):
    k = jax.random.split(jax.random.PRNGKey(seed), 5)
    return Transition(
        obs=jax.random.normal(k[0], (B, OBS)), context=jnp.zeros((B, 0)),
        action=jax.random.uniform(k[1], (B, ACT), minval=-1, maxval=1),
        reward=jax.random.normal(k[2], (B,)),
        next_obs=jax.random.normal(k[3], (B, OBS)),
        terminated=jax.random.bernoulli(k[4], 0.3, (B,)) if terminated is None
        else jnp.full((B,), terminated),
    )


def _perturbed(block, key=1):
    """A block state whose targets differ from the online networks (as after training)."""
    state = block.init(jax.random.PRNGKey(0))
    other = block.init(jax.random.PRNGKey(key))
    bump = lambda p: jax.tree_util.tree_map(lambda x: 3.0 * x, p)  # non-trivial values
    return state.replace(target_actor=other.actor, target_critic=bump(other.critic),
                         critic=bump(state.critic))


def _leaves_equal(a, b):
    same = jax.tree_util.tree_map(lambda x, y: np.array_equal(np.asarray(x), np.asarray(y)), a, b)
    return jax.tree_util.tree_all(same)


def close(a, b):
    np.testing.assert_allclose(a, b, rtol=1e-4, atol=1e-7)


def test_init_copies_online_into_target_networks():
    state = _block().init(jax.random.PRNGKey(0))
    assert isinstance(state, BlockState)
    assert _leaves_equal(state.actor, state.target_actor)
    assert _leaves_equal(state.critic, state.target_critic)
    lr_a, lr_c = DDPGBlock.learning_rates(state)
    assert lr_a.dtype == jnp.float32 and float(lr_a) == np.float32(1e-3)
    assert float(lr_c) == np.float32(1e-2)


@pytest.mark.parametrize("bad", [dict(hidden=()), dict(gamma=1.5), dict(tau=-0.1),
                                 dict(obs_dim=0)])
def test_invalid_block_names_the_field(bad):
    with pytest.raises(ValueError, match=next(iter(bad))):
        _block(**bad)


def test_target_bootstraps_unless_terminated():
    block = _block()
    state = _perturbed(block)
    batch = _batch()
    nq = block.q(state.target_critic, batch.next_obs,
                 block.mu(state.target_actor, batch.next_obs))
    assert float(jnp.abs(nq).mean()) > 0.01
    expected = batch.reward + 0.9 * (1.0 - batch.terminated) * nq
    np.testing.assert_allclose(block.target(state, batch), expected, rtol=1e-6, atol=1e-6)
    done = _batch(terminated=True)
    np.testing.assert_array_equal(block.target(state, done), done.reward)
    given = jnp.linspace(-3.0, 3.0, B)  # a next value given in place of Q'(s', μ'(s'))
    expected = batch.reward + 0.9 * (1.0 - batch.terminated) * given
    np.testing.assert_allclose(block.target(state, batch, next_q=given), expected, rtol=1e-6,
                               atol=1e-6)


def test_critic_update_reports_the_td_loss_and_reduces_it():
    block = _block()
    state = _perturbed(block)
    batch = _batch()
    y = block.target(state, batch)
    loss0 = jnp.mean((y - block.q(state.critic, batch.obs, batch.action)) ** 2)
    update = jax.jit(block.critic_update)
    new, metrics = update(state, batch)
    np.testing.assert_allclose(metrics["critic_loss"], loss0, rtol=1e-5)
    # actor and targets are untouched by a critic step
    assert _leaves_equal(new.actor, state.actor)
    assert _leaves_equal(new.target_critic, state.target_critic)
    many = jax.jit(lambda s: jax.lax.scan(lambda s, _: block.critic_update(s, batch), s,
                                          None, length=300))
    new, metrics = many(new)
    metrics = jax.tree_util.tree_map(lambda m: m[-1], metrics)
    assert float(metrics["critic_loss"]) < 0.02 * float(loss0)


def test_policy_gradient_is_the_chain_rule_through_the_critic():
    block = _block()
    state = _perturbed(block)
    obs = _batch().obs
    grads, metrics = block.policy_gradient(state, obs)
    neg_q = lambda p: -jnp.mean(block.q(state.critic, obs, block.mu(p, obs)))
    expected = jax.grad(neg_q)(state.actor)
    jax.tree_util.tree_map(close, grads, expected)
    np.testing.assert_allclose(metrics["actor_loss"], neg_q(state.actor), rtol=1e-6)


def test_extra_dq_da_enters_the_surrogate_loss():
    block = _block()
    state = _perturbed(block)
    obs = _batch().obs
    c = jnp.array([2.0, -3.0])
    extra = lambda o, a: jnp.sin(a) + c  # any function of (obs, action)
    grads, metrics = block.policy_gradient(state, obs, extra)

    def surrogate(p):
        a = block.mu(state.actor, obs)
        dq = jax.grad(lambda a: block.q(state.critic, obs, a).sum())(a) + extra(obs, a)
        return -jnp.mean(jnp.sum(jax.lax.stop_gradient(dq) * block.mu(p, obs), axis=-1))

    expected = jax.grad(surrogate)(state.actor)
    jax.tree_util.tree_map(close, grads, expected)
    assert float(metrics["dq_da_norm"]) > float(jnp.linalg.norm(c)) * 0.5


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_actor_update_with_extra_gradient_moves_the_action_that_way(sign):
    block = _block(actor_lr=1e-3)
    state = _perturbed(block)
    obs = _batch().obs
    extra = lambda o, a: sign * 10.0 * jnp.ones_like(a)
    update = jax.jit(block.actor_update, static_argnums=2)
    plain, pushed = state, state
    for _ in range(5):
        plain, _ = update(plain, obs, None)
        pushed, _ = update(pushed, obs, extra)
    diff = block.mu(pushed.actor, obs) - block.mu(plain.actor, obs)
    assert float(sign * diff.mean()) > 1e-3
    assert float((sign * diff > 0).mean()) > 0.9
    assert _leaves_equal(pushed.critic, state.critic)


def test_soft_update_is_exact_polyak_averaging():
    block = _block(tau=0.25)
    state = _perturbed(block)
    new = block.soft_update(state)
    expected = jax.tree_util.tree_map(lambda o, t: 0.25 * o + 0.75 * t,
                                      state.critic, state.target_critic)
    assert _leaves_equal(new.target_critic, expected)
    assert not _leaves_equal(new.target_critic, state.target_critic)
    assert _leaves_equal(block.soft_update(state, tau=1.0).target_actor, state.actor)
    assert _leaves_equal(block.soft_update(state, tau=0.0).target_actor, state.target_actor)
    assert _leaves_equal(new.actor, state.actor) and _leaves_equal(new.critic, state.critic)


def test_learning_rate_zero_freezes_parameters_under_jit():
    block = _block()
    state = _perturbed(block)
    batch = _batch()

    @jax.jit
    def step(state, lr):
        state = block.set_learning_rates(state, lr, 2 * lr)
        return block.update(state, batch)[0]

    frozen = step(state, jnp.float32(0.0))
    assert _leaves_equal(frozen.actor, state.actor) and _leaves_equal(frozen.critic, state.critic)
    moved = step(state, jnp.float32(1e-3))
    assert not _leaves_equal(moved.actor, state.actor)
    lr_a, lr_c = DDPGBlock.learning_rates(moved)
    assert float(lr_a) == np.float32(1e-3) and float(lr_c) == np.float32(2e-3)


def test_update_under_vmap_equals_separate_updates():
    block = _block()
    states = [block.init(jax.random.PRNGKey(s)) for s in range(3)]
    batches = [_batch(seed=s) for s in range(3)]
    stack = lambda xs: jax.tree_util.tree_map(lambda *x: jnp.stack(x), *xs)
    out, metrics = jax.jit(jax.vmap(block.update))(stack(states), stack(batches))
    update = jax.jit(block.update)
    for i in range(3):
        single, m = update(states[i], batches[i])
        got = jax.tree_util.tree_map(lambda x, i=i: x[i], out)
        jax.tree_util.tree_map(lambda a, b: np.testing.assert_allclose(a, b, rtol=1e-6,
                                                                       atol=1e-7), single, got)
        np.testing.assert_allclose(m["critic_loss"], metrics["critic_loss"][i], rtol=1e-6)


def test_huber_critic_loss_is_squared_near_the_target_and_linear_beyond():
    """``huber_delta``: the reported loss is the Huber loss of the TD errors, and a fit to
    targets with one outlier (the arm's collision, -100 among returns near -1) ends nearer
    the many than the squared error's fit does (the median-like pull, not the mean's)."""
    block = _block()
    state = _perturbed(block)
    batch = _batch(terminated=True)  # targets = rewards
    err = batch.reward - block.q(state.critic, batch.obs, batch.action)
    a = jnp.abs(err)
    expected = jnp.mean(jnp.where(a <= 1.0, 0.5 * err**2, a - 0.5))
    _, metrics = jax.jit(lambda s, b: block.critic_update(s, b, huber_delta=1.0))(state, batch)
    np.testing.assert_allclose(metrics["critic_loss"], expected, rtol=1e-5)

    # one observation, 31 targets of -1 and one of -100: the squared error fits the mean
    # (about -4.1), the Huber loss about -1 - 1/31 (a unit pull per outlier)
    same = batch.replace(obs=jnp.zeros((B, OBS)), action=jnp.zeros((B, ACT)),
                         reward=jnp.full((B,), -1.0).at[0].set(-100.0))

    def fit(delta: float | None) -> float:
        blk = _block(critic_lr=3e-2)
        s = blk.init(jax.random.PRNGKey(0))
        s = jax.lax.fori_loop(
            0, 2000, lambda _, s: blk.critic_update(s, same, huber_delta=delta)[0], s)
        return float(blk.q(s.critic, jnp.zeros(OBS), jnp.zeros(ACT)))

    fits = {delta: fit(delta) for delta in (None, 1.0)}
    assert abs(fits[None] - (-1.0 - 99.0 / B)) < 0.2, fits
    assert abs(fits[1.0] - (-1.0 - 1.0 / (B - 1))) < 0.2, fits

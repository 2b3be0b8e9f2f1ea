"""gated(): per-seed results of a plain cond, but a real branch under the named seed vmap."""

import jax
import jax.extend.core
import jax.numpy as jnp
import numpy as np
import pytest

from hiddpg.agents.gate import SEED_AXIS, gated, seed_axis_bound


def update(x):
    return {"w": x["w"] * 2.0 + 1.0, "n": x["n"] + 1}


def skip(x):
    return x


def run(pred, x):
    return gated(pred, update, skip, x)


def primitives(jaxpr) -> set[str]:
    out = set()
    for eqn in jaxpr.eqns:
        out.add(eqn.primitive.name)
        for sub in jax.extend.core.jaxprs_in_params(eqn.params):
            out |= primitives(sub)
    return out


@pytest.mark.parametrize("preds", [[True, False, True], [False, False, False], [True] * 3])
def test_each_seed_gets_exactly_its_own_branch(preds):
    x = {"w": jnp.array([[1.0, 2.0], [3.0, 4.0], [5.0, 6.0]]), "n": jnp.array([0, 10, 20])}
    pred = jnp.array(preds)
    named = jax.jit(jax.vmap(run, axis_name=SEED_AXIS))(pred, x)
    plain = jax.jit(jax.vmap(run))(pred, x)
    for i, p in enumerate(preds):
        own = {k: v[i] for k, v in x.items()}
        want = update(own) if p else own
        for k in x:
            np.testing.assert_array_equal(named[k][i], want[k])
            np.testing.assert_array_equal(plain[k][i], want[k])


def test_named_vmap_keeps_a_branch_plain_vmap_does_not():
    x = {"w": jnp.ones((4, 3)), "n": jnp.zeros((4,), jnp.int32)}
    pred = jnp.array([True, False, False, True])
    named = jax.make_jaxpr(jax.vmap(run, axis_name=SEED_AXIS))(pred, x)
    plain = jax.make_jaxpr(jax.vmap(run))(pred, x)
    assert "cond" in primitives(named.jaxpr)  # lax.switch: skip / some seeds / all seeds
    assert "cond" not in primitives(plain.jaxpr)  # vmap turned the cond into a select


def test_axis_detection():
    seen = []

    def probe(x):
        seen.append(seed_axis_bound())  # decided at trace time
        return x

    assert not seed_axis_bound()
    jax.vmap(probe, axis_name=SEED_AXIS)(jnp.zeros(3))
    jax.vmap(probe)(jnp.zeros(3))
    jax.vmap(probe, axis_name="other")(jnp.zeros(3))
    assert seen == [True, False, False]


def test_outside_a_seed_vmap_it_is_a_plain_cond():
    x = {"w": jnp.ones(2), "n": jnp.zeros((), jnp.int32)}
    assert float(jax.jit(run)(jnp.array(True), x)["w"][0]) == 3.0
    assert float(jax.jit(run)(jnp.array(False), x)["w"][0]) == 1.0
    assert "cond" in primitives(jax.make_jaxpr(run)(jnp.array(True), x).jaxpr)

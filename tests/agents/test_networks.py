"""Actor, critic and MLP: architecture of paper §II-D, output ranges and initialisation."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from hiddpg.agents.networks import FINAL_INIT_SCALE, MLP, Actor, Critic

OBS, ACT = 5, 3


def _kernel_shapes(params):
    return {name: layer["kernel"].shape for name, layer in params["params"].items()}


def test_critic_takes_the_action_at_the_first_hidden_layer():
    critic = Critic((16, 8))
    params = critic.init(jax.random.PRNGKey(0), jnp.zeros((1, OBS)), jnp.zeros((1, ACT)))
    assert _kernel_shapes(params) == {
        "hidden_0": (OBS, 16),            # the input layer sees the state only
        "hidden_1": (16 + ACT, 8),        # the action joins the first hidden layer's output
        "out": (8, 1),
    }


def test_critic_with_one_hidden_layer_feeds_the_action_to_the_output():
    critic = Critic((16,))
    params = critic.init(jax.random.PRNGKey(0), jnp.zeros((1, OBS)), jnp.zeros((1, ACT)))
    assert _kernel_shapes(params) == {"hidden_0": (OBS, 16), "out": (16 + ACT, 1)}


def test_action_acts_only_through_its_rows_of_the_second_layer():
    critic = Critic((16, 8))
    key_p, key_o, key_a = jax.random.split(jax.random.PRNGKey(1), 3)
    params = critic.init(key_p, jnp.zeros((1, OBS)), jnp.zeros((1, ACT)))
    obs = jax.random.normal(key_o, (32, OBS))
    action = jax.random.uniform(key_a, (32, ACT), minval=-1, maxval=1)
    dq_da = jax.grad(lambda a: critic.apply(params, obs, a).sum())(action)
    assert float(jnp.abs(dq_da).max()) > 0
    # zero the action rows (the last ACT inputs of hidden_1): Q no longer depends on the action
    cut = jax.tree_util.tree_map(lambda x: x, params)
    cut["params"]["hidden_1"]["kernel"] = params["params"]["hidden_1"]["kernel"].at[16:].set(0.0)
    q1 = critic.apply(cut, obs, action)
    q2 = critic.apply(cut, obs, -action)
    np.testing.assert_array_equal(np.asarray(q1), np.asarray(q2))
    dq_dobs = jax.grad(lambda o: critic.apply(cut, o, action).sum())(obs)
    assert float(jnp.abs(dq_dobs).max()) > 0


def test_critic_output_is_scalar_per_sample():
    critic = Critic((16, 8))
    params = critic.init(jax.random.PRNGKey(0), jnp.zeros((1, OBS)), jnp.zeros((1, ACT)))
    assert critic.apply(params, jnp.ones((7, OBS)), jnp.ones((7, ACT))).shape == (7,)
    assert critic.apply(params, jnp.ones(OBS), jnp.ones(ACT)).shape == ()


def test_actor_output_is_bounded_and_shaped():
    actor = Actor((16, 16), ACT)
    params = actor.init(jax.random.PRNGKey(0), jnp.zeros((1, OBS)))
    big = jax.tree_util.tree_map(lambda x: 1e3 * x, params)
    obs = 1e3 * jax.random.normal(jax.random.PRNGKey(2), (100, OBS))
    out = actor.apply(big, obs)
    assert out.shape == (100, ACT)
    assert float(jnp.abs(out).max()) <= 1.0
    assert float(jnp.abs(out).max()) > 0.99  # saturates: the tanh is really there
    assert actor.apply(params, jnp.zeros(OBS)).shape == (ACT,)


@pytest.mark.parametrize("net", ["actor", "critic"])
def test_initialisation_follows_the_ddpg_paper(net):
    key = jax.random.PRNGKey(3)
    if net == "actor":
        params = Actor((64, 32), ACT).init(key, jnp.zeros((1, OBS)))["params"]
    else:
        params = Critic((64, 32)).init(key, jnp.zeros((1, OBS)), jnp.zeros((1, ACT)))["params"]
    for name, layer in params.items():
        w, b = layer["kernel"], layer["bias"]
        if name == "out":
            bound = FINAL_INIT_SCALE
            assert float(jnp.abs(b).max()) <= bound
        else:
            bound = 1.0 / np.sqrt(w.shape[0])
            np.testing.assert_array_equal(np.asarray(b), 0.0)
        assert float(jnp.abs(w).max()) <= bound
        assert float(jnp.abs(w).max()) > 0.8 * bound  # uniform over the whole range
    # so the initial outputs are near 0
    if net == "actor":
        out = Actor((64, 32), ACT).apply({"params": params}, jnp.ones((4, OBS)))
        assert float(jnp.abs(out).max()) < 0.05


def test_mlp_has_a_linear_output_of_the_given_size():
    mlp = MLP((16, 16), 4)
    params = mlp.init(jax.random.PRNGKey(0), jnp.zeros((1, OBS)))
    assert _kernel_shapes(params)["out"] == (16, 4)
    assert mlp.apply(params, jnp.ones((9, OBS))).shape == (9, 4)
    linear = MLP((), 2)  # no hidden layer: an affine map
    lp = linear.init(jax.random.PRNGKey(1), jnp.zeros((1, OBS)))
    x = jax.random.normal(jax.random.PRNGKey(2), (3, OBS))
    b = lp["params"]["out"]["bias"]
    np.testing.assert_allclose(linear.apply(lp, 10 * x) - b, 10 * (linear.apply(lp, x) - b),
                               rtol=1e-5, atol=1e-5)

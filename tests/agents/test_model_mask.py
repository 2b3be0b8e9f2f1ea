"""The model-based term's terminal mask (spec §3): a transition that ended the episode has no
successor value, so its model term is 0 with ``model_masked`` (the default) and kept without."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from hiddpg.agents import buffer
from hiddpg.agents.level import Level
from hiddpg.agents.transition import Transition
from hiddpg.configs import LevelConfig


def test_model_term_is_masked_where_the_episode_ended():
    """Spec §3: the model-based term of a transition with ``terminated`` is 0 (no successor
    value); the others are the unmasked term, and ``model_masked=False`` keeps all."""

    cfg = LevelConfig(hidden=(16, 16))
    masked = Level(config=cfg, state_dim=4, context_dim=4, action_dim=2, time_scale=0.1,
                   model_weight=1.0, use_model=True)
    plain = Level(config=cfg, state_dim=4, context_dim=4, action_dim=2, time_scale=0.1,
                  model_weight=1.0, use_model=True, model_masked=False)
    state = masked.init(jax.random.PRNGKey(0))
    inputs = jax.random.normal(jax.random.PRNGKey(1), (3, 8))
    a = jax.random.uniform(jax.random.PRNGKey(2), (3, 2), minval=-1, maxval=1)
    terminated = jnp.array([True, False, True])
    full = masked.extra_dq_da(state.block, state.model)(inputs, a)
    cut = masked.extra_dq_da(state.block, state.model, terminated)(inputs, a)
    assert float(jnp.abs(full).min()) > 0
    np.testing.assert_array_equal(cut[1], full[1])
    np.testing.assert_array_equal(cut[jnp.array([0, 2])], 0.0)
    assert plain.model_masked is False and masked.model_masked is True


def test_level_update_masks_the_model_term_of_terminal_transitions():
    """One ``Level.update`` on a buffer of terminal transitions: with the mask the actor moves
    exactly as without a model term (λ = 0); unmasked it moves differently."""

    cfg = LevelConfig(hidden=(16, 16), batch_size=8, buffer_size=8)
    kw = dict(config=cfg, state_dim=4, context_dim=4, action_dim=2, time_scale=0.1,
              use_model=True)
    levels = {"masked": Level(model_weight=1.0, **kw), "none": Level(model_weight=0.0, **kw),
              "unmasked": Level(model_weight=1.0, model_masked=False, **kw)}
    state = levels["masked"].init(jax.random.PRNGKey(0))
    ks = jax.random.split(jax.random.PRNGKey(3), 5)
    for i in range(8):
        tr = Transition(obs=jax.random.normal(ks[0] + i, (4,)),
                        context=jax.random.normal(ks[1] + i, (4,)),
                        action=jax.random.uniform(ks[2] + i, (2,), minval=-1, maxval=1),
                        reward=jnp.asarray(-1.0), next_obs=jax.random.normal(ks[3] + i, (4,)),
                        terminated=jnp.asarray(True))
        state = state.replace(buffer=buffer.add(state.buffer, tr))
    actors = {name: level.update(state, jax.random.PRNGKey(7), episode=jnp.asarray(1))[0]
              .block.actor for name, level in levels.items()}
    same = jax.tree.map(np.testing.assert_array_equal, actors["masked"], actors["none"])
    assert same is not None
    diff = jax.tree.leaves(jax.tree.map(lambda a, b: float(jnp.abs(a - b).max()),
                                        actors["unmasked"], actors["none"]))
    assert max(diff) > 0

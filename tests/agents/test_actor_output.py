"""The actor's output layer: ``tanh`` (spec §1) or ``linear`` (the paper's §II-D). A linear
actor's action is clipped to the unit box wherever it is used (acting, critic targets) and
differentiated unclipped in the policy gradient, so its gradient does not vanish outside the
box the way a saturated ``tanh``'s does."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from hiddpg.agents.block import DDPGBlock
from hiddpg.presets import make_config
from hiddpg.train import Trainer, seed_keys

OBS, ACT = 3, 2


def block(output: str) -> DDPGBlock:
    return DDPGBlock(obs_dim=OBS, action_dim=ACT, hidden=(16, 16), actor_lr=1e-3,
                     critic_lr=1e-3, gamma=0.9, tau=0.1, actor_output=output)


def pushed_out(b: DDPGBlock):
    """A state whose actor's final bias is +5: the raw output is far above the box."""
    state = b.init(jax.random.PRNGKey(0))
    params = jax.tree_util.tree_map(lambda x: x, state.actor)
    params["params"]["out"]["bias"] = jnp.full((ACT,), 5.0)
    return state.replace(actor=params)


def test_linear_output_is_clipped_where_used_and_differentiated_unclipped():
    b = block("linear")
    state = pushed_out(b)
    obs = jax.random.normal(jax.random.PRNGKey(1), (8, OBS))
    raw = b.raw(state.actor, obs)
    assert float(raw.min()) > 1.5  # outside the box
    np.testing.assert_array_equal(b.mu(state.actor, obs), jnp.ones((8, ACT)))
    np.testing.assert_array_equal(b.act(state, obs), jnp.ones((8, ACT)))
    grads, _ = b.policy_gradient(state, obs)
    assert float(jnp.abs(grads["params"]["out"]["bias"]).max()) > 1e-4
    t = block("tanh")
    tstate = pushed_out(t)
    tgrads, _ = t.policy_gradient(tstate, obs)
    # tanh(>= 5) is saturated: its bias gradient is smaller by orders of magnitude
    assert (float(jnp.abs(tgrads["params"]["out"]["bias"]).max())
            < 1e-2 * float(jnp.abs(grads["params"]["out"]["bias"]).max()))


def test_tanh_is_the_default_and_bad_values_are_named():
    assert block("tanh").actor_output == "tanh"
    with pytest.raises(ValueError, match="actor_output='relu'"):
        block("relu")
    with pytest.raises(ValueError, match="actor_output"):
        make_config("ddpg", "PuckTrajectory1", "quick", ["agent.actor_output=relu"])


@pytest.mark.parametrize("algo", ["ddpg", "hi-ddpg", "h-ddpg"])
def test_linear_actors_train_with_actions_in_bounds(algo):
    key = {"ddpg": "agent.actor_output", "hi-ddpg": "agent.low.actor_output",
           "h-ddpg": "agent.skill.actor_output"}[algo]
    starts = "agent.skill.learning_starts" if algo == "h-ddpg" else "agent.learning_starts"
    sets = ["episodes=6", "eval_every=3", "chunk_episodes=6", f"{starts}=40", f"{key}=linear"]
    if algo == "hi-ddpg":
        sets += ["agent.high.actor_output=linear", "agent.high_learning_starts=4"]
    cfg = make_config(algo, "PuckTrajectory1", "quick", sets)
    trainer = Trainer(cfg)
    state = trainer.init_seeds(seed_keys([0]))
    state, train_m, _ = trainer.run_chunk_seeds(state, 6)
    losses = [v for k, v in train_m.items() if "loss" in k]
    assert losses and all(np.isfinite(np.asarray(v)).all() for v in losses)
    _, traj = trainer.evaluate_seeds(state, seed_keys([0]))
    actions = np.asarray(traj["action"])
    assert np.all(np.abs(actions) <= trainer.env.action_high + 1e-6)

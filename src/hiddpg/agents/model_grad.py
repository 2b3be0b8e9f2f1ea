"""Learned dynamics models and the model-based action gradient (paper §II-C, eqs. 6-7, Fig. 2).

Each level of HI-DDPG has a dynamics network:

* low level, ``M_L(s, a) -> ṡ``; the prediction is ``ŝ' = s + Δt M_L(s, a)`` and the model is
  trained by mean squared error on ``(s' - s) / Δt`` (paper: "the gradient of the next state to
  the current action is equivalent to the gradient of ṡ scaled by Δt");
* high level, ``M_H(s, (g, T)) -> ŝ_{i+1}``, predicting the change ``s_{i+1} - s_i``
  internally (``time_scale = 1``).

Both are :class:`DynamicsModel` with a different ``time_scale``. The model-based gradient adds to
the actor's action gradient ``∂Q/∂a`` the term

    λ · ∂V(ŝ')/∂ŝ' · ∂ŝ'/∂a,     V(x) = Q(x, μ(x)),

evaluated at ``a = μ(s)`` with the actor's parameters held fixed: :func:`model_gradient` is the
``jax.grad`` of ``a ↦ V(predict(s, a))``, which by the chain rule is exactly that product.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence

import jax
import jax.numpy as jnp
import optax
from flax import struct

from hiddpg.agents.block import with_learning_rate
from hiddpg.agents.networks import MLP


@struct.dataclass
class ModelState:
    """Parameters and Adam state of a dynamics model."""

    params: dict
    opt_state: optax.OptState


@dataclasses.dataclass(frozen=True)
class DynamicsModel:
    """``predict(s, a) = s + time_scale * net([s, a])``, trained on ``(s' - s) / time_scale``.

    Attributes:
        obs_dim, action_dim: input sizes (the action in the actor's unit box).
        hidden: hidden layer sizes.
        lr: Adam learning rate (a level shares one rate between actor, critic and model).
        time_scale: ``Δt`` for the low level (the net predicts ``ṡ``), 1 for the high level.
    """

    obs_dim: int
    action_dim: int
    hidden: Sequence[int]
    lr: float
    time_scale: float = 1.0

    @property
    def net(self) -> MLP:
        return MLP(tuple(self.hidden), self.obs_dim)

    @property
    def optimizer(self) -> optax.GradientTransformation:
        return optax.inject_hyperparams(optax.adam)(learning_rate=self.lr)

    def init(self, key: jax.Array) -> ModelState:
        x = jnp.zeros((self.obs_dim + self.action_dim,), jnp.float32)
        params = self.net.init(key, x)
        state = ModelState(params=params, opt_state=self.optimizer.init(params))
        return self.set_learning_rate(state, self.lr)  # a float32 array, as in scan carries

    def predict(self, params: dict, obs: jax.Array, action: jax.Array) -> jax.Array:
        """The predicted next state ``ŝ'``."""
        rate = self.net.apply(params, jnp.concatenate([obs, action], axis=-1))
        return obs + self.time_scale * rate

    def loss(self, params: dict, obs: jax.Array, action: jax.Array, next_obs: jax.Array):
        """Mean squared error of the predicted rate ``(s' - s) / time_scale``."""
        target = (next_obs - obs) / self.time_scale
        rate = self.net.apply(params, jnp.concatenate([obs, action], axis=-1))
        return jnp.mean(jnp.sum((rate - target) ** 2, axis=-1))

    def update(self, state: ModelState, obs, action, next_obs) -> tuple[ModelState, jax.Array]:
        """One Adam step on a batch (paper Alg. 1 lines 12 and 20)."""
        loss, grads = jax.value_and_grad(self.loss)(state.params, obs, action, next_obs)
        updates, opt_state = self.optimizer.update(grads, state.opt_state, state.params)
        return ModelState(optax.apply_updates(state.params, updates), opt_state), loss

    def set_learning_rate(self, state: ModelState, lr: jax.Array | float) -> ModelState:
        """Replace the Adam learning rate (traced values allowed: used for decay)."""
        return state.replace(opt_state=with_learning_rate(state.opt_state, lr))


def model_gradient(
    value: Callable[[jax.Array], jax.Array],
    predict: Callable[[jax.Array], jax.Array],
    action: jax.Array,
) -> jax.Array:
    """``∂V(ŝ')/∂ŝ' · ∂ŝ'/∂a`` for ONE sample: ``value`` maps a next state to ``V``, ``predict``
    maps an action to the predicted next state ``ŝ'``. Returns an array shaped like ``action``.
    """
    return jax.grad(lambda a: value(predict(a)))(action)


def batched_model_gradient(
    value: Callable[[jax.Array, jax.Array], jax.Array],
    predict: Callable[[jax.Array, jax.Array], jax.Array],
    inputs: jax.Array,
    action: jax.Array,
) -> jax.Array:
    """:func:`model_gradient` over a batch. For sample ``i`` with actor input ``inputs[i]``
    (the state, or the state and goal), ``predict(inputs[i], a)`` is the predicted next state
    and ``value(inputs[i], x)`` the value of next state ``x`` (the goal, if any, is read from
    ``inputs[i]``)."""

    def one(inp: jax.Array, a: jax.Array) -> jax.Array:
        return model_gradient(lambda x: value(inp, x), lambda a_: predict(inp, a_), a)

    return jax.vmap(one)(inputs, action)

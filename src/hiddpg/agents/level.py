"""One level of HI-DDPG: a DDPG block, a dynamics model and a replay buffer (paper Fig. 2).

Both levels have the same shape: the actor sees ``[s, c]`` — the state and a *context* (the
goal for the low level; nothing for the paper's high level) — and outputs a unit action; the
model predicts the next state from ``(s, a)``; the value of a predicted next state ``x`` is
``V(x) = Q([x, c], μ([x, c]))``. One update (Alg. 1 lines 12 and 16-20) is:

1. critic step on a minibatch (eq. 3 / eq. 5 with the discount of Alg. 1 line 17);
2. actor step along ``∂Q/∂a + λ ∂V(ŝ')/∂ŝ' ∂ŝ'/∂a`` (eqs. 2, 4, 6, 7);
3. model step (if the model is used);
4. soft target update.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
from flax import struct

from hiddpg.agents import buffer, huber
from hiddpg.agents.block import BlockState, DDPGBlock
from hiddpg.agents.gate import gated
from hiddpg.agents.hindsight import Hindsight
from hiddpg.agents.model_grad import DynamicsModel, ModelState, batched_model_gradient
from hiddpg.agents.streams import split_named
from hiddpg.agents.transition import Transition, example
from hiddpg.configs import LevelConfig

#: ``(block, block_state, next_obs) -> value`` of the critic target's next states.
NextValue = Callable[[DDPGBlock, BlockState, jax.Array], jax.Array]
#: ``(key, inputs) -> inputs``: the actor's batch rewritten.
ActorInputs = Callable[[jax.Array, jax.Array], jax.Array]


@struct.dataclass
class LevelState:
    block: BlockState
    model: ModelState
    buffer: buffer.ReplayBuffer


@dataclasses.dataclass(frozen=True)
class Level:
    """Static description of a level.

    Attributes:
        config: the level's hyper-parameters.
        state_dim: size of ``s`` (the observation).
        context_dim: size of ``c``.
        action_dim: size of the unit action.
        time_scale: the model's ``Δt`` (low level: the env's control period; high level: 1).
        model_weight: λ of the model-based gradient (0 switches the term off).
        use_model: whether the model is trained.
        model_masked: the model-based term is multiplied by ``1 - terminated`` of each sampled
            transition (no successor value where the episode ended).
        hindsight: hindsight goals for the minibatches (:mod:`hiddpg.agents.hindsight`), or
            None.
    """

    config: LevelConfig
    state_dim: int
    context_dim: int
    action_dim: int
    time_scale: float
    model_weight: float
    use_model: bool
    hindsight: Hindsight | None = None
    model_masked: bool = True

    @property
    def block(self) -> DDPGBlock:
        c = self.config
        return DDPGBlock(obs_dim=self.state_dim + self.context_dim, action_dim=self.action_dim,
                         hidden=tuple(c.hidden), actor_lr=c.lr, critic_lr=c.lr, gamma=c.gamma,
                         tau=c.tau, invert_gradients=c.invert_gradients, action_l2=c.action_l2,
                         actor_output=c.actor_output)

    @property
    def model(self) -> DynamicsModel:
        return DynamicsModel(obs_dim=self.state_dim, action_dim=self.action_dim,
                             hidden=tuple(self.config.hidden), lr=self.config.lr,
                             time_scale=self.time_scale)

    def init(self, key: jax.Array) -> LevelState:
        k_block, k_model = jax.random.split(key)
        tr = example(self.state_dim, self.action_dim, self.context_dim,
                     hindsight=self.hindsight is not None)
        return LevelState(block=self.block.init(k_block), model=self.model.init(k_model),
                          buffer=buffer.init(tr, self.config.buffer_size))

    def act(self, state: LevelState, s: jax.Array, c: jax.Array) -> jax.Array:
        """The noise-free unit action ``μ([s, c])``."""
        return self.block.act(state.block, jnp.concatenate([s, c], axis=-1))

    def store(self, state: LevelState, transition: Transition, mask: jax.Array) -> LevelState:
        return state.replace(buffer=buffer.add(state.buffer, transition, mask))

    def set_learning_rate(self, state: LevelState, lr: jax.Array) -> LevelState:
        return state.replace(block=self.block.set_learning_rates(state.block, lr, lr),
                             model=self.model.set_learning_rate(state.model, lr))

    # -- the model-based gradient -----------------------------------------------------------
    def extra_dq_da(self, block_state: BlockState, model_state: ModelState,
                    terminated: jax.Array | None = None):
        """``(inputs, a) -> λ (1 - terminated) ∂V(ŝ')/∂ŝ' ∂ŝ'/∂a`` for the block's actor step
        (spec §3); ``terminated`` (the batch's flags) None: unmasked."""
        n, block, model, lam = self.state_dim, self.block, self.model, self.model_weight
        if terminated is not None:
            lam = lam * (1.0 - terminated.astype(jnp.float32))[:, None]
        critic = block_state.critic
        actor = jax.lax.stop_gradient(block_state.actor)

        def predict(inp: jax.Array, a: jax.Array) -> jax.Array:
            return model.predict(model_state.params, inp[:n], a)

        def value(inp: jax.Array, x: jax.Array) -> jax.Array:
            xc = jnp.concatenate([x, inp[n:]])
            return block.q(critic, xc, block.mu(actor, xc))

        return lambda inputs, a: lam * batched_model_gradient(value, predict, inputs, a)

    # -- one update -------------------------------------------------------------------------
    def sample(self, state: LevelState, key: jax.Array) -> Transition:
        """A minibatch from the level's buffer (with hindsight goals, if any)."""
        if self.hindsight is None:
            return buffer.sample(state.buffer, key, self.config.batch_size)
        return self.hindsight.sample(state.buffer, key, self.config.batch_size)

    def update(self, state: LevelState, key: jax.Array, *, episode: jax.Array,
               next_value: NextValue | None = None,
               actor_inputs: ActorInputs | None = None) -> tuple[LevelState, dict]:
        """Critic, actor (with the model-based term), model and target updates on one batch.

        ``next_value``, if given, values the critic target's next states instead of
        ``Q'(s', μ'(s'))``; ``actor_inputs``, if given, rewrites the actor's batch of ``[s, c]``
        (both: :mod:`hiddpg.agents.durations`). ``episode`` (the agent's count) sets the Huber
        loss's ``δ`` where the config schedules it."""
        keys = update_keys(key)
        tr = self.sample(state, keys["sample"])
        block, c = self.block, self.config
        delta = None if c.huber is None else huber.delta_at(c.huber, episode)
        next_q = None if next_value is None else next_value(block, state.block, tr.next_obs)
        block_state, critic_m = block.critic_update(state.block, tr, next_q=next_q,
                                                    huber_delta=delta)
        extra = None
        if self.model_weight > 0:
            mask = tr.terminated if self.model_masked else None
            extra = self.extra_dq_da(block_state, state.model, mask)
        inputs = tr.inputs
        if actor_inputs is not None:
            inputs = actor_inputs(keys["actor_inputs"], inputs)
        block_state, actor_m = block.actor_update(block_state, inputs, extra)
        block_state = block.soft_update(block_state)
        model_state, model_loss = state.model, jnp.zeros(())
        if self.use_model:
            model_state, model_loss = self.model.update(state.model, tr.obs, tr.action,
                                                        tr.next_obs)
        metrics = {"critic_loss": critic_m["critic_loss"], "actor_loss": actor_m["actor_loss"],
                   "model_loss": model_loss, "q_mean": critic_m["q_mean"],
                   "dq_da_norm": actor_m["dq_da_norm"]}
        return state.replace(block=block_state, model=model_state), metrics

    def maybe_update(self, state: LevelState, key: jax.Array, do: jax.Array, *,
                     episode: jax.Array, next_value: NextValue | None = None,
                     actor_inputs: ActorInputs | None = None) -> tuple[LevelState, dict]:
        """:meth:`update` if ``do`` else nothing (a branch even under the seed ``vmap``)."""
        return gated(do, lambda s: self.update(s, key, episode=episode, next_value=next_value,
                                               actor_inputs=actor_inputs),
                     lambda s: (s, zero_metrics()), state)


def update_keys(key: jax.Array) -> dict[str, jax.Array]:
    """An update's random streams: the minibatch's ``"sample"`` and ``"actor_inputs"``."""
    return split_named(key, ("sample", "actor_inputs"))


def zero_metrics() -> dict[str, Any]:
    """The metrics of an update that did not happen (same keys as :meth:`Level.update`)."""
    return {k: jnp.zeros(()) for k in ("critic_loss", "actor_loss", "model_loss", "q_mean",
                                       "dq_da_norm")}

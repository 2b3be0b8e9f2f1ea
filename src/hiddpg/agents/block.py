"""The DDPG block shared by flat DDPG, both levels of HI-DDPG and the skills of h-DDPG (spec §1).

A :class:`DDPGBlock` is a frozen, static description (sizes, learning rates, discount, Polyak
rate) holding the flax modules and the optax optimisers; a :class:`BlockState` pytree holds the
parameters of actor, critic, their target copies and both Adam states. Every method is a pure
function of its arguments, safe under ``jit`` and ``vmap``.

The paper's equations (§II-A):

* critic (eq. 3): minimise ``(y − Q(s, a))²`` with ``y = r + γ (1 − terminated) Q'(s', μ'(s'))``;
  truncated transitions bootstrap, terminated ones do not;
* actor (eq. 2): ``∇θ J = E[∇a Q(s, a)|a=μ(s) ∇θ μ(s)]``. Following Acme's TD3 learner, the
  action gradient ``dq_da`` is computed *explicitly*; :meth:`DDPGBlock.actor_update` adds an
  optional ``extra_dq_da(obs, a)`` to it — the seam where HI-DDPG adds the model-based term
  ``λ ∂V/∂ŝ' ∂ŝ'/∂a`` (eqs. 6–7, spec §3) — and then minimises the surrogate
  ``−mean(Σ_a stop_gradient(dq_da) · μθ(s))``, whose gradient is the policy gradient above;
* targets (DDPG): Polyak averaging ``θ' ← τ θ + (1 − τ) θ'``.

Learning rates live in the optimiser states (``optax.inject_hyperparams``) so that they can be
decayed inside ``jit`` with :meth:`DDPGBlock.set_learning_rates`.

[decision] marks a value of ours where the paper is silent; docs/deviations.md (each with the
paper's value and why) lists them.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import jax
import jax.numpy as jnp
import optax
from flax import struct

from hiddpg.agents.networks import ACTOR_OUTPUTS, Actor, Critic
from hiddpg.agents.transition import Transition

#: extra action gradient ``(obs, a) -> array shaped like a`` added to ``dQ/da``.
ExtraDqDa = Callable[[jax.Array, jax.Array], jax.Array]


@struct.dataclass
class BlockState:
    """Parameters and optimiser states of one actor–critic pair.

    Attributes:
        actor, critic: online parameters ``θ^μ``, ``θ^Q``.
        target_actor, target_critic: target parameters ``θ^μ'``, ``θ^Q'``.
        actor_opt, critic_opt: Adam states (``inject_hyperparams``: the learning rate is in
            ``opt.hyperparams["learning_rate"]``).
    """

    actor: Any
    critic: Any
    target_actor: Any
    target_critic: Any
    actor_opt: Any
    critic_opt: Any


def _adam(lr: float) -> optax.GradientTransformation:
    return optax.inject_hyperparams(optax.adam)(learning_rate=lr)


def with_learning_rate(opt_state: Any, lr: jax.Array | float) -> Any:
    old = opt_state.hyperparams["learning_rate"]
    hyper = dict(opt_state.hyperparams, learning_rate=jnp.asarray(lr, jnp.float32).reshape(
        jnp.shape(old)))
    return opt_state._replace(hyperparams=hyper)


def invert_gradients(dq_da: jax.Array, action: jax.Array) -> jax.Array:
    """Hausknecht & Stone (2016): scale an action gradient that points towards a bound of the
    unit box by the distance left to it, ``(1 − a)/2`` upwards and ``(a + 1)/2`` downwards, so
    the actor approaches the bounds smoothly and ``tanh`` does not saturate [decision]."""
    return jnp.where(dq_da > 0, dq_da * (1.0 - action), dq_da * (action + 1.0)) * 0.5


@dataclass(frozen=True)
class DDPGBlock:
    """One DDPG actor–critic pair (static description + pure functions).

    Attributes:
        obs_dim: input size of actor and critic (HI-DDPG's low level: ``2 * state_dim``).
        action_dim: output size of the actor (unit box ``[-1, 1]``).
        hidden: hidden layer sizes of actor and critic.
        actor_lr, critic_lr: initial Adam learning rates.
        gamma: discount of the critic target (overridable per sample, see :meth:`target`).
        tau: Polyak rate of the target networks.
        invert_gradients: bound the action gradient near the box edges
            (:func:`invert_gradients`) [decision; off = plain DDPG].
        action_l2: weight of a penalty ``action_l2 · |μ(s)|²`` on the unit action in the actor's
            objective (as in Andrychowicz et al. 2017's DDPG), keeping ``tanh`` out of
            saturation [decision; 0 = plain DDPG].
    """

    obs_dim: int
    action_dim: int
    hidden: tuple[int, ...]
    actor_lr: float
    critic_lr: float
    gamma: float
    tau: float
    invert_gradients: bool = False
    action_l2: float = 0.0
    actor_output: str = "tanh"
    actor_net: Actor = field(init=False, repr=False, compare=False)
    critic_net: Critic = field(init=False, repr=False, compare=False)
    actor_tx: optax.GradientTransformation = field(init=False, repr=False, compare=False)
    critic_tx: optax.GradientTransformation = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        for name in ("obs_dim", "action_dim"):
            v = getattr(self, name)
            if not (isinstance(v, int) and v > 0):
                raise ValueError(f"DDPGBlock.{name}={v!r} must be a positive int")
        hidden = tuple(self.hidden)
        if not hidden or any(not isinstance(n, int) or n <= 0 for n in hidden):
            raise ValueError(f"DDPGBlock.hidden={self.hidden!r} must be positive ints")
        for name, lo, hi in (("actor_lr", 0, None), ("critic_lr", 0, None),
                             ("gamma", 0, 1), ("tau", 0, 1)):
            v = getattr(self, name)
            if not (v >= lo and (hi is None or v <= hi)):
                raise ValueError(f"DDPGBlock.{name}={v!r} out of range [{lo}, {hi or 'inf'}]")
        if self.actor_output not in ACTOR_OUTPUTS:
            raise ValueError(f"DDPGBlock.actor_output={self.actor_output!r} must be one of "
                             f"{ACTOR_OUTPUTS}")
        setattr_ = object.__setattr__
        setattr_(self, "hidden", hidden)
        setattr_(self, "actor_net", Actor(hidden, self.action_dim, output=self.actor_output))
        setattr_(self, "critic_net", Critic(hidden))
        setattr_(self, "actor_tx", _adam(self.actor_lr))
        setattr_(self, "critic_tx", _adam(self.critic_lr))

    # -- construction and evaluation ----------------------------------------------------------
    def init(self, key: jax.Array) -> BlockState:
        """Fresh parameters (targets are copies of the online networks) and Adam states."""
        k_actor, k_critic = jax.random.split(key)
        obs = jnp.zeros((1, self.obs_dim), jnp.float32)
        action = jnp.zeros((1, self.action_dim), jnp.float32)
        actor = self.actor_net.init(k_actor, obs)
        critic = self.critic_net.init(k_critic, obs, action)
        state = BlockState(
            actor=actor, critic=critic, target_actor=actor, target_critic=critic,
            actor_opt=self.actor_tx.init(actor), critic_opt=self.critic_tx.init(critic),
        )
        # store the rates as float32 arrays so that scan carries keep one dtype
        return self.set_learning_rates(state, self.actor_lr, self.critic_lr)

    def raw(self, actor_params: Any, obs: jax.Array) -> jax.Array:
        """The actor network's output: ``tanh``-bounded, or unbounded for a linear output."""
        return self.actor_net.apply(actor_params, obs)

    def mu(self, actor_params: Any, obs: jax.Array) -> jax.Array:
        """The policy ``μ(s|θ^μ)`` in ``[-1, 1]^action_dim`` (any leading batch shape): the
        ``tanh`` output, or the linear output clipped to the box. The actor's gradient
        (:meth:`policy_gradient`) differentiates the unclipped output."""
        out = self.raw(actor_params, obs)
        return out if self.actor_output == "tanh" else jnp.clip(out, -1.0, 1.0)

    def act(self, state: BlockState, obs: jax.Array) -> jax.Array:
        """The online actor's unit action for ``obs`` (no noise)."""
        return self.mu(state.actor, obs)

    def q(self, critic_params: Any, obs: jax.Array, action: jax.Array) -> jax.Array:
        """``Q(s, a|θ^Q)``: shape ``obs.shape[:-1]``."""
        return self.critic_net.apply(critic_params, obs, action)

    # -- critic (eq. 3) -----------------------------------------------------------------------
    def target(self, state: BlockState, batch: Transition,
               next_q: jax.Array | None = None) -> jax.Array:
        """``y = r + γ (1 − terminated) Q'(s', μ'(s'))``; ``next_q``, if given, replaces the
        next state's value ``Q'(s', μ'(s'))``. No gradient flows through ``y``."""
        if next_q is None:
            next_obs = batch.next_inputs
            next_q = self.q(state.target_critic, next_obs, self.mu(state.target_actor, next_obs))
        not_done = 1.0 - jnp.asarray(batch.terminated, jnp.float32)
        return jax.lax.stop_gradient(batch.reward + self.gamma * not_done * next_q)

    def critic_update(self, state: BlockState, batch: Transition, *,
                      next_q: jax.Array | None = None,
                      huber_delta: jax.Array | float | None = None) -> tuple[BlockState, dict]:
        """One Adam step on the mean squared TD error, or with ``huber_delta`` the mean Huber
        loss (:mod:`hiddpg.agents.huber`). Metrics: ``critic_loss`` (before the step),
        ``q_mean``."""
        y = self.target(state, batch, next_q)
        inputs = batch.inputs

        def loss_fn(critic: Any) -> tuple[jax.Array, jax.Array]:
            q = self.q(critic, inputs, batch.action)
            if huber_delta is not None:
                return jnp.mean(optax.huber_loss(q, y, delta=huber_delta)), q
            return jnp.mean((y - q) ** 2), q

        (loss, q), grads = jax.value_and_grad(loss_fn, has_aux=True)(state.critic)
        updates, opt = self.critic_tx.update(grads, state.critic_opt, state.critic)
        critic = optax.apply_updates(state.critic, updates)
        metrics = {"critic_loss": loss, "q_mean": jnp.mean(q)}
        return state.replace(critic=critic, critic_opt=opt), metrics

    # -- actor (eq. 2, with the seam of eqs. 6-7) ---------------------------------------------
    def action_gradient(
        self, critic_params: Any, obs: jax.Array, action: jax.Array
    ) -> tuple[jax.Array, jax.Array]:
        """``(Q(s, a), ∂Q/∂a)`` per sample (``∂Q/∂a`` has the shape of ``action``)."""
        q, vjp = jax.vjp(lambda a: self.q(critic_params, obs, a), action)
        (dq_da,) = vjp(jnp.ones_like(q))
        return q, dq_da

    def policy_gradient(
        self, state: BlockState, obs: jax.Array, extra_dq_da: ExtraDqDa | None = None
    ) -> tuple[Any, dict]:
        """Gradient of the actor loss w.r.t. ``θ^μ``: ``−mean_b (dq_da_b · ∂μ(s_b)/∂θ)`` with
        ``dq_da = ∂Q/∂a|a=μ(s) (+ extra_dq_da(obs, μ(s)))``, plus metrics ``actor_loss =
        −mean Q(s, μ(s))`` and ``dq_da_norm`` (mean L2 norm of the total action gradient)."""
        action, pullback = jax.vjp(lambda p: self.raw(p, obs), state.actor)
        q, dq_da = self.action_gradient(state.critic, obs, action)
        if extra_dq_da is not None:
            dq_da = dq_da + extra_dq_da(obs, action)
        if self.action_l2:
            dq_da = dq_da - 2.0 * self.action_l2 * action
        if self.invert_gradients:
            dq_da = invert_gradients(dq_da, action)
        dq_da = jax.lax.stop_gradient(dq_da)
        # d/dθ of −mean(Σ_a dq_da · μθ(s)) is the pullback of −dq_da / batch
        n = max(int(jnp.size(q)), 1)
        (grads,) = pullback(-dq_da / n)
        metrics = {
            "actor_loss": -jnp.mean(q),
            "dq_da_norm": jnp.mean(jnp.linalg.norm(dq_da, axis=-1)),
        }
        return grads, metrics

    def actor_update(
        self, state: BlockState, obs: jax.Array, extra_dq_da: ExtraDqDa | None = None
    ) -> tuple[BlockState, dict]:
        """One Adam step of the actor along the deterministic policy gradient (eq. 2)."""
        grads, metrics = self.policy_gradient(state, obs, extra_dq_da)
        updates, opt = self.actor_tx.update(grads, state.actor_opt, state.actor)
        actor = optax.apply_updates(state.actor, updates)
        return state.replace(actor=actor, actor_opt=opt), metrics

    # -- targets, learning rates, the whole step ----------------------------------------------
    def soft_update(self, state: BlockState, tau: float | jax.Array | None = None) -> BlockState:
        """Polyak averaging ``θ' ← τ θ + (1 − τ) θ'`` of both target networks."""
        tau = self.tau if tau is None else tau
        mix = lambda online, target: tau * online + (1.0 - tau) * target
        return state.replace(
            target_actor=jax.tree_util.tree_map(mix, state.actor, state.target_actor),
            target_critic=jax.tree_util.tree_map(mix, state.critic, state.target_critic),
        )

    def set_learning_rates(
        self, state: BlockState, actor_lr: jax.Array | float, critic_lr: jax.Array | float
    ) -> BlockState:
        """Replace both Adam learning rates (traced values allowed: used for decay)."""
        return state.replace(
            actor_opt=with_learning_rate(state.actor_opt, actor_lr),
            critic_opt=with_learning_rate(state.critic_opt, critic_lr),
        )

    @staticmethod
    def learning_rates(state: BlockState) -> tuple[jax.Array, jax.Array]:
        """The current ``(actor_lr, critic_lr)``."""
        return (state.actor_opt.hyperparams["learning_rate"],
                state.critic_opt.hyperparams["learning_rate"])

    def update(
        self, state: BlockState, batch: Transition, extra_dq_da: ExtraDqDa | None = None
    ) -> tuple[BlockState, dict]:
        """The DDPG step of Alg. 1 (lines 10-12 / 17-19): critic update, then actor update on
        the batch's inputs with the updated critic, then the soft target update."""
        state, critic_metrics = self.critic_update(state, batch)
        state, actor_metrics = self.actor_update(state, batch.inputs, extra_dq_da)
        return self.soft_update(state), {**critic_metrics, **actor_metrics}


def value_terminal(res: Any, end_is_terminal: bool, env_terminal: bool = True) -> jax.Array:
    """The ``terminated`` flag a stored transition gets from an environment step ``res``: the
    environment's own (unless ``env_terminal`` is False: then the value bootstraps through it),
    or also the time limit when ``end_is_terminal`` (no bootstrap at the end of any episode;
    see ``DDPGConfig.end_is_terminal``)."""
    terminated = jnp.asarray(res.terminated, bool)
    if not env_terminal:
        terminated = jnp.zeros_like(terminated)
    if end_is_terminal:
        terminated = terminated | jnp.asarray(res.truncated, bool)
    return terminated

"""Flat DDPG (the paper's "plain DDPG" baseline, spec §1) as an :class:`~hiddpg.agents.base.Agent`.

One :class:`~hiddpg.agents.block.DDPGBlock` acts on the environment reward. Per environment step:

1. action: uniformly random in the unit box for the first ``learning_starts`` environment steps
   of the run (a global counter), afterwards ``clip(μ(s) + noise, -1, 1)`` with OU noise reset
   every episode; the unit action is mapped affinely onto ``[env.action_low, env.action_high]``;
2. the transition ``(s, a_unit, r, s', terminated)`` is inserted into the replay buffer;
3. once learning started, one critic update, one actor update and one soft target update on a
   uniformly sampled minibatch (Alg. 1's low-level lines 9-12 without the hierarchy).

Episodes run in the shared harness (:mod:`hiddpg.agents.episode`): the fixed length
``env.max_steps(params)`` inside ``lax.scan``, nothing inserted, learned or counted after the
episode's end, learning rates multiplied by ``lr_decay`` every ``lr_decay_every`` episodes.

Example::

    agent = make_ddpg(DDPGConfig(), env)
    state = agent.init(key, params)
    state, metrics = jax.jit(agent.train_episode)(key, state, params)
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import jax
import jax.numpy as jnp
from flax import struct

from hiddpg.agents import buffer as replay
from hiddpg.agents import noise
from hiddpg.agents.block import BlockState, DDPGBlock, value_terminal
from hiddpg.agents.episode import EpisodeMetrics, decay_factor, run_episode
from hiddpg.agents.gate import gated
from hiddpg.agents.streams import split_named
from hiddpg.agents.transition import Transition, example
from hiddpg.configs import DDPGConfig
from hiddpg.envs.base import Environment, affine_unit


@struct.dataclass
class DDPGState:
    """Everything flat DDPG carries between episodes.

    Attributes:
        block: actor/critic parameters and optimiser states.
        buffer: the replay buffer of :class:`~hiddpg.agents.transition.Transition` (the
            action in the unit box).
        env_steps: int32, environment steps taken in this run (drives ``learning_starts``).
        episodes: int32, training episodes finished (drives the learning-rate decay).
    """

    block: BlockState
    buffer: replay.ReplayBuffer
    env_steps: jax.Array
    episodes: jax.Array


#: one training step's random streams
STREAMS = ("random", "noise", "env", "sample")


@dataclass(frozen=True)
class DDPGAgent:
    """Flat DDPG on one environment (see module docstring). Build with :func:`make_ddpg`."""

    config: DDPGConfig
    env: Environment
    block: DDPGBlock = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        c = self.config
        object.__setattr__(self, "block", DDPGBlock(
            obs_dim=self.env.obs_dim, action_dim=self.env.action_dim, hidden=c.hidden,
            actor_lr=c.actor_lr, critic_lr=c.critic_lr, gamma=c.gamma, tau=c.tau,
            invert_gradients=c.invert_gradients, action_l2=c.action_l2,
            actor_output=c.actor_output,
        ))

    @property
    def learning_starts(self) -> int:
        return self.config.learning_starts

    def to_env_action(self, unit: jax.Array) -> jax.Array:
        """Map the unit box ``[-1, 1]`` affinely onto ``[env.action_low, env.action_high]``."""
        low, high = float(self.env.action_low), float(self.env.action_high)
        if (low, high) == (-1.0, 1.0):
            return unit
        return affine_unit(unit, low, high)

    # -- the Agent protocol -------------------------------------------------------------------
    def init(self, key: jax.Array, env_params: Any) -> DDPGState:
        """Fresh networks, an empty replay buffer and zero counters."""
        del env_params  # shapes come from the static env description
        zero = jnp.zeros((), jnp.int32)
        return DDPGState(
            block=self.block.init(key),
            buffer=replay.init(example(self.env.obs_dim, self.env.action_dim),
                               self.config.buffer_size),
            env_steps=zero, episodes=zero,
        )

    def train_episode(
        self, key: jax.Array, state: DDPGState, env_params: Any
    ) -> tuple[DDPGState, dict[str, jax.Array]]:
        """One episode of exploration, replay insertion and learning (see module docstring)."""
        state, metrics, _ = run_episode(self, key, state, env_params, train=True)
        return state, metrics.as_dict()

    def evaluate(
        self, key: jax.Array, state: DDPGState, env_params: Any
    ) -> tuple[dict[str, jax.Array], dict[str, jax.Array]]:
        """One noise-free episode without learning: ``(metrics, trajectory)``; the trajectory has
        ``obs`` (before each action), ``action`` (in the env's box), ``reward`` (0 after the
        end) and ``alive`` (1.0 while the episode runs), each with leading axis the horizon."""
        _, metrics, traj = run_episode(self, key, state, env_params, train=False)
        return metrics.as_dict(), traj

    # -- the episode harness's hooks (hiddpg.agents.episode) ---------------------------------
    def step_keys(self, key: jax.Array, train: bool) -> dict[str, jax.Array]:
        return split_named(key, STREAMS) if train else {"env": key}

    def decay(self, state: DDPGState) -> DDPGState:
        c = self.config
        factor = decay_factor(c.lr_decay, c.lr_decay_every, state.episodes)
        return state.replace(block=self.block.set_learning_rates(
            state.block, c.actor_lr * factor, c.critic_lr * factor))

    def begin(self, state: DDPGState, obs: jax.Array, horizon: int, train: bool):
        f0 = jnp.zeros((), jnp.float32)
        sums = {"ret": f0, "length": jnp.zeros((), jnp.int32), "critic_loss": f0,
                "actor_loss": f0, "updates": jnp.zeros((), jnp.int32)}
        return noise.init(self.config.noise, self.env.action_dim), sums

    def act(self, state: DDPGState, inner: Any, obs: jax.Array, alive: jax.Array, keys: dict,
            random_phase: jax.Array, env_params: Any, horizon: int, train: bool):
        """``clip(μ(s) + OU, -1, 1)``, uniform in the random phase; ``μ(s)`` in evaluation."""
        unit = self.block.act(state.block, obs)
        if train:
            uniform = jax.random.uniform(keys["random"], (self.env.action_dim,), jnp.float32,
                                         -1.0, 1.0)
            inner, eps = noise.sample(self.config.noise, inner, keys["noise"], state.episodes)
            unit = jnp.where(random_phase, uniform, jnp.clip(unit + eps, -1.0, 1.0))
        return inner, self.to_env_action(unit), unit

    def observe(self, state: DDPGState, inner: Any, obs: jax.Array, unit: jax.Array, res: Any,
                alive: jax.Array, keys: dict, random_phase: jax.Array, horizon: int,
                train: bool):
        """Store ``(s, a, r, s', terminated)`` and learn on a minibatch (training)."""
        reward = jnp.where(alive, jnp.asarray(res.reward, jnp.float32), 0.0)
        adds = {"ret": reward, "length": alive.astype(jnp.int32)}
        out = {"obs": obs, "action": self.to_env_action(unit), "reward": reward,
               "alive": alive.astype(jnp.float32)}
        if not train:
            return state, inner, adds, out
        c, f0 = self.config, jnp.zeros((), jnp.float32)
        transition = Transition(
            obs=obs, context=jnp.zeros((0,)), action=unit,
            reward=jnp.asarray(res.reward, jnp.float32),
            next_obs=jnp.asarray(res.obs, jnp.float32),
            terminated=value_terminal(res, c.end_is_terminal))
        buf = replay.add(state.buffer, transition, alive)
        do_update = alive & ~random_phase

        def learn(bs: BlockState) -> tuple[BlockState, jax.Array, jax.Array]:
            bs, m = self.block.update(bs, replay.sample(buf, keys["sample"], c.batch_size))
            return bs, m["critic_loss"], m["actor_loss"]

        block_state, closs, aloss = gated(do_update, learn, lambda bs: (bs, f0, f0), state.block)
        state = state.replace(block=block_state, buffer=buf,
                              env_steps=state.env_steps + alive.astype(jnp.int32))
        adds.update(critic_loss=closs, actor_loss=aloss, updates=do_update.astype(jnp.int32))
        return state, inner, adds, out

    def finish(self, state: DDPGState, inner: Any, sums: dict, traj: dict, train: bool):
        zero = jnp.zeros((), jnp.int32)
        if not train:  # the evaluation's return sums the trajectory's rewards at once
            ret = traj["reward"].sum()
            return state, EpisodeMetrics(ret, ret, sums["length"], zero, {})
        n = jnp.maximum(sums["updates"], 1).astype(jnp.float32)
        state = state.replace(episodes=state.episodes + 1)
        extra = {"critic_loss": sums["critic_loss"] / n, "actor_loss": sums["actor_loss"] / n,
                 "env_steps": state.env_steps}
        return state, EpisodeMetrics(sums["ret"], sums["ret"], sums["length"], zero, extra)


def make_ddpg(config: DDPGConfig, env: Environment) -> DDPGAgent:
    """Flat DDPG for ``env`` with ``config`` (an :class:`~hiddpg.agents.base.Agent`)."""
    return DDPGAgent(config=config, env=env)

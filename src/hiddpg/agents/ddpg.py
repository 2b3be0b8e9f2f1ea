"""Flat DDPG (the paper's "plain DDPG" baseline, spec §1) as an :class:`~hiddpg.agents.base.Agent`.

One :class:`~hiddpg.agents.block.DDPGBlock` acts on the environment reward. Per environment step:

1. action: uniformly random in the unit box for the first ``learning_starts`` environment steps
   of the run (a global counter), afterwards ``clip(μ(s) + noise, -1, 1)`` with OU noise reset
   every episode; the unit action is mapped affinely onto ``[env.action_low, env.action_high]``;
2. the transition ``(s, a_unit, r, s', terminated)`` is inserted into the replay buffer;
3. once learning started, one critic update, one actor update and one soft target update on a
   uniformly sampled minibatch (Alg. 1's low-level lines 9-12 without the hierarchy).

Episodes have the fixed length ``env.max_steps(params)`` inside ``lax.scan``; after the episode
ended the environment state is frozen and nothing is inserted, learned or counted. Learning
rates are multiplied by ``lr_decay`` every ``lr_decay_every`` episodes.

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
from hiddpg.agents.gate import gated
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


@struct.dataclass
class _Carry:
    """Per-step scan carry of a training episode."""

    agent: DDPGState
    obs: jax.Array
    env_state: Any
    noise: noise.NoiseState
    alive: jax.Array
    ret: jax.Array
    length: jax.Array
    critic_loss: jax.Array
    actor_loss: jax.Array
    updates: jax.Array


def _select(pred: jax.Array, new: Any, old: Any) -> Any:
    return jax.tree_util.tree_map(lambda n, o: jnp.where(pred, n, o), new, old)


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
        ))

    # -- helpers ------------------------------------------------------------------------------
    def to_env_action(self, unit: jax.Array) -> jax.Array:
        """Map the unit box ``[-1, 1]`` affinely onto ``[env.action_low, env.action_high]``."""
        low, high = float(self.env.action_low), float(self.env.action_high)
        if (low, high) == (-1.0, 1.0):
            return unit
        return affine_unit(unit, low, high)

    def _learning_rates(self, episodes: jax.Array) -> tuple[jax.Array, jax.Array]:
        c = self.config
        factor = jnp.float32(c.lr_decay) ** (episodes // c.lr_decay_every).astype(jnp.float32)
        return c.actor_lr * factor, c.critic_lr * factor

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
        c, block = self.config, self.block
        k_reset, k_steps = jax.random.split(key)
        obs, env_state = self.env.reset(k_reset, env_params)
        actor_lr, critic_lr = self._learning_rates(state.episodes)
        state = state.replace(block=block.set_learning_rates(state.block, actor_lr, critic_lr))
        f0 = jnp.zeros((), jnp.float32)
        carry = _Carry(
            agent=state, obs=jnp.asarray(obs, jnp.float32), env_state=env_state,
            noise=noise.init(c.noise, self.env.action_dim), alive=jnp.ones((), bool),
            ret=f0, length=jnp.zeros((), jnp.int32), critic_loss=f0, actor_loss=f0,
            updates=jnp.zeros((), jnp.int32),
        )

        def step(carry: _Carry, key: jax.Array) -> tuple[_Carry, None]:
            k_random, k_noise, k_env, k_sample = jax.random.split(key, 4)
            agent = carry.agent
            random_action = jax.random.uniform(
                k_random, (self.env.action_dim,), jnp.float32, -1.0, 1.0)
            noise_state, eps = noise.sample(c.noise, carry.noise, k_noise, agent.episodes)
            explore = jnp.clip(block.act(agent.block, carry.obs) + eps, -1.0, 1.0)
            learning = agent.env_steps >= c.learning_starts
            unit = jnp.where(learning, explore, random_action)
            res = self.env.step(k_env, carry.env_state, self.to_env_action(unit), env_params)
            next_obs = jnp.asarray(res.obs, jnp.float32)
            transition = Transition(
                obs=carry.obs, context=jnp.zeros((0,)), action=unit,
                reward=jnp.asarray(res.reward, jnp.float32), next_obs=next_obs,
                terminated=value_terminal(res, c.end_is_terminal))
            alive = carry.alive
            buf = replay.add(agent.buffer, transition, alive)
            do_update = alive & learning

            def learn(bs: BlockState) -> tuple[BlockState, jax.Array, jax.Array]:
                batch = replay.sample(buf, k_sample, c.batch_size)
                bs, m = block.update(bs, batch)
                return bs, m["critic_loss"], m["actor_loss"]

            def skip(bs: BlockState) -> tuple[BlockState, jax.Array, jax.Array]:
                return bs, f0, f0

            block_state, closs, aloss = gated(do_update, learn, skip, agent.block)
            agent = agent.replace(block=block_state, buffer=buf,
                                  env_steps=agent.env_steps + alive.astype(jnp.int32))
            ended = jnp.asarray(res.terminated, bool) | jnp.asarray(res.truncated, bool)
            carry = _Carry(
                agent=agent,
                obs=jnp.where(alive, next_obs, carry.obs),
                env_state=_select(alive, res.state, carry.env_state),
                noise=noise_state,
                alive=alive & ~ended,
                ret=carry.ret + jnp.where(alive, transition.reward, 0.0),
                length=carry.length + alive.astype(jnp.int32),
                critic_loss=carry.critic_loss + closs,
                actor_loss=carry.actor_loss + aloss,
                updates=carry.updates + do_update.astype(jnp.int32),
            )
            return carry, None

        horizon = self.env.max_steps(env_params)
        carry, _ = jax.lax.scan(step, carry, jax.random.split(k_steps, horizon))
        n = jnp.maximum(carry.updates, 1).astype(jnp.float32)
        state = carry.agent.replace(episodes=carry.agent.episodes + 1)
        metrics = {
            "return": carry.ret, "env_return": carry.ret, "length": carry.length,
            "switches": jnp.zeros((), jnp.int32),
            "critic_loss": carry.critic_loss / n, "actor_loss": carry.actor_loss / n,
            "env_steps": state.env_steps,
        }
        return state, metrics

    def evaluate(
        self, key: jax.Array, state: DDPGState, env_params: Any
    ) -> tuple[dict[str, jax.Array], dict[str, jax.Array]]:
        """One noise-free episode without learning: ``(metrics, trajectory)``; the trajectory has
        ``obs`` (before each action), ``action`` (in the env's box), ``reward`` (0 after the
        end) and ``alive`` (1.0 while the episode runs), each with leading axis the horizon."""
        k_reset, k_steps = jax.random.split(key)
        obs, env_state = self.env.reset(k_reset, env_params)

        def step(carry: tuple, key: jax.Array) -> tuple[tuple, dict]:
            obs, env_state, alive = carry
            action = self.to_env_action(self.block.act(state.block, obs))
            res = self.env.step(key, env_state, action, env_params)
            reward = jnp.where(alive, jnp.asarray(res.reward, jnp.float32), 0.0)
            out = {"obs": obs, "action": action, "reward": reward,
                   "alive": alive.astype(jnp.float32)}
            ended = jnp.asarray(res.terminated, bool) | jnp.asarray(res.truncated, bool)
            next_obs = jnp.where(alive, jnp.asarray(res.obs, jnp.float32), obs)
            env_state = _select(alive, res.state, env_state)
            return (next_obs, env_state, alive & ~ended), out

        init = (jnp.asarray(obs, jnp.float32), env_state, jnp.ones((), bool))
        horizon = self.env.max_steps(env_params)
        _, traj = jax.lax.scan(step, init, jax.random.split(k_steps, horizon))
        ret = traj["reward"].sum()
        metrics = {
            "return": ret, "env_return": ret,
            "length": traj["alive"].sum().astype(jnp.int32),
            "switches": jnp.zeros((), jnp.int32),
        }
        return metrics, traj


def make_ddpg(config: DDPGConfig, env: Environment) -> DDPGAgent:
    """Flat DDPG for ``env`` with ``config`` (an :class:`~hiddpg.agents.base.Agent`)."""
    return DDPGAgent(config=config, env=env)

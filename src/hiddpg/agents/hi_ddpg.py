"""HI-DDPG: hierarchical intermittent DDPG, the paper's Algorithm 1 (§II-B/C; spec §2-3).

At switch points the high level chooses a goal ``g`` and a duration ``T`` (line 7); the low
level acts on ``[s, g]`` for ``n = clip(round(T), 1, steps left)`` steps (9-10), stores its
transitions with the intrinsic reward and learns every step (11-12); at the segment's end the
high level gets ``f = Σ r_env - c_switch [not the first goal]`` (14), stores the segment in
``D_H`` and learns (15-20). One episode is a ``lax.scan`` over the horizon; the switch is a
mask (every step computes the high level's candidate and keeps it where a segment starts).

Where the paper leaves a choice open (spec §2): the first ``learning_starts`` environment steps
use uniformly random goals, durations and actions; during the first ``pretrain_episodes``
episodes the high level is bypassed (uniformly random goals and durations). Our additions are
parts plugged in at one seam each: how the high level chooses (:mod:`~hiddpg.agents.choice`),
hindsight (:mod:`~hiddpg.agents.hindsight`), the intrinsic reward's rest term
(:mod:`~hiddpg.agents.intrinsic`), the critics' Huber loss (:mod:`~hiddpg.agents.huber`).
"""

from __future__ import annotations

import dataclasses
from functools import cached_property
from typing import Any

import jax
import jax.numpy as jnp
from flax import struct

from hiddpg.agents import noise
from hiddpg.agents.block import value_terminal
from hiddpg.agents.choice import Chooser, make_chooser
from hiddpg.agents.hindsight import Hindsight, high_relabel
from hiddpg.agents.intrinsic import IntrinsicReward
from hiddpg.agents.level import Level, LevelState
from hiddpg.agents.streams import split_named
from hiddpg.agents.transition import Transition
from hiddpg.configs import HIDDPGConfig
from hiddpg.envs.base import Environment, affine_unit

_LOSSES = ("critic_loss", "actor_loss", "model_loss")

#: the random streams of one step, one per purpose
STREAMS = ("high_noise", "high_random", "low_noise", "low_random", "env", "low_update",
           "high_update")


@struct.dataclass
class HIDDPGState:
    high: LevelState
    low: LevelState
    env_steps: jax.Array
    episodes: jax.Array


@struct.dataclass
class _Carry:
    env_state: Any
    obs: jax.Array
    alive: jax.Array
    high_action: jax.Array  # unit box: goal entries then T
    goal: jax.Array  # full goal vector (obs shape)
    remaining: jax.Array  # low-level steps left in the segment
    seg_obs: jax.Array  # s_{t_i}, the high level's input
    seg_reward: jax.Array  # Σ r_env so far in the segment
    n_goals: jax.Array
    high_noise: noise.NoiseState
    low_noise: noise.NoiseState
    agent: HIDDPGState
    sums: dict


@dataclasses.dataclass(frozen=True)
class HIDDPG:
    """The HI-DDPG agent for one environment (implements :class:`hiddpg.agents.base.Agent`)."""

    config: HIDDPGConfig
    env: Environment

    @cached_property
    def choice(self) -> Chooser:
        """How the high level chooses, stores and learns (:mod:`hiddpg.agents.choice`)."""
        return make_chooser(self.config, self.env.obs_dim, self.env.goal_space)

    @property
    def high(self) -> Level:
        return self.choice.level

    @cached_property
    def intrinsic_reward(self) -> IntrinsicReward:
        """``r_int(s', g)`` (spec §2)."""
        return IntrinsicReward(self.env.goal_space, self.env.obs_dim, self.config.rest_term)

    @cached_property
    def low(self) -> Level:
        c, env = self.config, self.env
        hindsight = None
        if c.low_hindsight is not None:
            hindsight = Hindsight(c.low_hindsight.fraction, env.goal_space, env.obs_dim,
                                  self.intrinsic_reward)
        return Level(c.low, state_dim=env.obs_dim, context_dim=env.obs_dim,
                     action_dim=env.action_dim, time_scale=float(env.dt),
                     model_weight=c.model_weight, use_model=c.use_model, hindsight=hindsight)

    @property
    def goal_dim(self) -> int:
        return self.env.goal_space.dim

    def decode(self, high_action: jax.Array) -> tuple[jax.Array, jax.Array]:
        """Unit high-level action → (full goal vector, continuous duration ``T``)."""
        return self.choice.decode(high_action)

    def env_action(self, unit: jax.Array) -> jax.Array:
        return affine_unit(unit, self.env.action_low, self.env.action_high)

    def init(self, key: jax.Array, env_params: Any) -> HIDDPGState:
        """Alg. 1 lines 1-2: the networks of both levels and empty buffers."""
        del env_params
        k_high, k_low = jax.random.split(key)
        zero = jnp.zeros((), jnp.int32)
        return HIDDPGState(self.high.init(k_high), self.low.init(k_low), zero, zero)

    # -- Alg. 1 line 7: the high level chooses (g, T), with OU noise -----------------------------
    def choose(self, carry: _Carry, hobs: jax.Array, steps_left: jax.Array, keys: dict,
               noise_eps: jax.Array | None, random: jax.Array) -> jax.Array:
        """The unit ``(g, T)`` at a switch; ``noise_eps`` (training) explores it, ``random``
        (random phase or pre-training) replaces it by a uniform draw."""
        high = carry.agent.high
        action = self.choice.propose(high, hobs, steps_left)
        train = noise_eps is not None
        if train:
            action = self.choice.explore(high, hobs, action, noise_eps, steps_left,
                                         keys["choice_explore"])
            uniform = jax.random.uniform(keys["high_random"], action.shape, minval=-1.0,
                                         maxval=1.0)
            action = jnp.where(random, uniform, action)
        return self.choice.settle(high, hobs, action, steps_left, keys["choice_settle"], train,
                                  ~random)

    # -- Alg. 1 line 9: the low level acts on [s, g] ---------------------------------------------
    def low_policy(self, low: LevelState, obs: jax.Array, goal: jax.Array,
                   env_params: Any) -> jax.Array:
        """The noise-free unit action ``μ_L(s, g)``."""
        del env_params
        return self.low.act(low, obs, goal)

    def low_explore(self, action: jax.Array, noise_state: noise.NoiseState, keys: dict,
                    random_phase: jax.Array, episodes: jax.Array):
        """``(action with OU noise, or uniform in the random phase; the noise's state)``."""
        noise_state, eps = noise.sample(self.config.low.noise, noise_state, keys["low_noise"],
                                        episodes)
        uniform = jax.random.uniform(keys["low_random"], action.shape, minval=-1.0, maxval=1.0)
        return jnp.where(random_phase, uniform, jnp.clip(action + eps, -1.0, 1.0)), noise_state

    # -- Alg. 1 line 12: the low level learns ----------------------------------------------------
    def low_update(self, low: LevelState, key: jax.Array, do: jax.Array, episode: jax.Array):
        return self.low.maybe_update(low, key, do, episode=episode)

    # -- one episode -----------------------------------------------------------------------------
    def _decay(self, state: HIDDPGState) -> HIDDPGState:
        c = self.config
        factor = c.lr_decay ** (state.episodes // c.lr_decay_every).astype(jnp.float32)
        return state.replace(
            high=self.high.set_learning_rate(state.high, c.high.lr * factor),
            low=self.low.set_learning_rate(state.low, c.low.lr * factor),
        )

    def _episode(self, key: jax.Array, state: HIDDPGState, env_params: Any, train: bool):
        """Alg. 1 lines 4-6: a new OU process, the initial state, the steps of one episode."""
        env, horizon = self.env, self.env.max_steps(env_params)
        k_reset, k_steps = jax.random.split(key)
        obs, env_state = env.reset(k_reset, env_params)
        zeros = {f"{lv}_{m}": jnp.zeros(()) for lv in ("high", "low") for m in _LOSSES}
        carry = _Carry(
            env_state=env_state, obs=obs, alive=jnp.array(True),
            high_action=jnp.zeros((self.goal_dim + 1,)), goal=jnp.zeros_like(obs),
            remaining=jnp.zeros((), jnp.int32),
            seg_obs=self.choice.inputs(obs, jnp.asarray(horizon), horizon),
            seg_reward=jnp.zeros(()), n_goals=jnp.zeros((), jnp.int32),
            high_noise=noise.init(self.config.high.noise, self.goal_dim + 1),
            low_noise=noise.init(self.config.low.noise, env.action_dim),
            agent=self._decay(state) if train else state,
            sums=dict(zeros, high_updates=jnp.zeros(()), low_updates=jnp.zeros(()),
                      env_return=jnp.zeros(()), ret=jnp.zeros(()), length=jnp.zeros(())),
        )
        step = lambda c, k: self._step(c, k, env_params, horizon, train)  # noqa: E731
        return jax.lax.scan(step, carry, jax.random.split(k_steps, horizon))

    def _step(self, carry: _Carry, key: jax.Array, env_params: Any, horizon: int, train: bool):
        c, env, choice = self.config, self.env, self.choice
        keys = step_keys(key)
        agent = carry.agent
        random_phase = agent.env_steps < c.learning_starts
        pretrain = agent.episodes < c.pretrain_episodes
        # line 7: at a switch, the high level chooses (g, T)
        switch = carry.alive & (carry.remaining <= 0)
        steps_left = horizon - carry.env_state.t
        hobs = choice.inputs(carry.obs, steps_left, horizon)
        high_noise, eps = carry.high_noise, None
        if train:
            new_noise, eps = noise.sample(c.high.noise, high_noise, keys["high_noise"],
                                          agent.episodes)
            high_noise = jax.tree.map(lambda a, b: jnp.where(switch, a, b), new_noise, high_noise)
        explore_random = (random_phase | pretrain) if train else jnp.array(False)
        high_action = self.choose(carry, hobs, steps_left, keys, eps, explore_random)
        high_action = jnp.where(switch, high_action, carry.high_action)
        goal, duration = self.decode(high_action)
        n = jnp.clip(jnp.round(duration), 1, steps_left).astype(jnp.int32)
        high_action = jnp.where(switch, choice.carried(high_action, n), high_action)
        remaining = jnp.where(switch, n, carry.remaining)
        seg_obs = jnp.where(switch, hobs, carry.seg_obs)
        seg_reward = jnp.where(switch, 0.0, carry.seg_reward)
        n_goals = carry.n_goals + switch.astype(jnp.int32)
        # lines 9-10: the low level acts on [s, g]; r_int measures how well g is reached
        action = self.low_policy(agent.low, carry.obs, goal, env_params)
        low_noise = carry.low_noise
        if train:
            action, low_noise = self.low_explore(action, low_noise, keys, random_phase,
                                                 agent.episodes)
        env_action = self.env_action(action)
        res = env.step(keys["env"], carry.env_state, env_action, env_params)
        alive = carry.alive
        r_env = jnp.where(alive, res.reward, 0.0)
        done = res.terminated | res.truncated
        r_int = self.intrinsic_reward(res.obs, goal)
        remaining = remaining - 1
        seg_reward = seg_reward + r_env
        seg_end = alive & ((remaining <= 0) | done)
        # line 14: the high level's reward, the switch cost for every goal after the first
        f = seg_reward - c.switch_cost * (n_goals > 1)
        sums = dict(carry.sums)
        if train:
            low_tr = Transition(
                obs=carry.obs, context=goal, action=action, reward=r_int, next_obs=res.obs,
                terminated=value_terminal(res, c.low.end_is_terminal, c.low.env_terminal),
                **({"episode": agent.episodes, "steps_left": steps_left - 1}
                   if self.low.hindsight is not None else {}))
            context, act = choice.stored(high_action)
            act = self.relabel_high(act, res, keys["high_hindsight"])
            high_tr = Transition(
                obs=seg_obs, context=context, action=act, reward=f,
                next_obs=choice.inputs(res.obs, steps_left - 1, horizon),
                terminated=value_terminal(res, c.high.end_is_terminal, c.high.env_terminal))
            # lines 11 and 15: D_L every step, D_H at a segment's end
            store_high = ~pretrain | c.pretrain_fills_high_buffer
            agent = agent.replace(low=self.low.store(agent.low, low_tr, alive),
                                  high=self.high.store(agent.high, high_tr, seg_end & store_high))
            # lines 12 and 16-20: one low-level update a step, one high-level one a segment
            started = agent.env_steps >= c.learning_starts
            learn_low = alive & started
            high_tick = seg_end if c.high_update_on == "segment" else alive
            learn_high = (high_tick & started & ~pretrain
                          & (agent.high.buffer.size >= c.high_learning_starts))
            low_state, low_m = self.low_update(agent.low, keys["low_update"], learn_low,
                                               agent.episodes)
            high_state, high_m = choice.update(agent.high, keys["high_update"], learn_high,
                                               episode=agent.episodes, horizon=horizon)
            agent = agent.replace(low=low_state, high=high_state,
                                  env_steps=agent.env_steps + alive.astype(jnp.int32))
            for m in _LOSSES:
                sums[f"low_{m}"] = sums[f"low_{m}"] + low_m[m]
                sums[f"high_{m}"] = sums[f"high_{m}"] + high_m[m]
            sums["low_updates"] = sums["low_updates"] + learn_low
            sums["high_updates"] = sums["high_updates"] + learn_high
        sums["env_return"] = sums["env_return"] + r_env
        sums["ret"] = sums["ret"] + jnp.where(seg_end, f, 0.0)
        sums["length"] = sums["length"] + alive
        env_state = jax.tree.map(lambda a, b: jnp.where(alive, a, b), res.state, carry.env_state)
        new = _Carry(
            env_state=env_state, obs=jnp.where(alive, res.obs, carry.obs), alive=alive & ~done,
            high_action=high_action, goal=goal, remaining=remaining, seg_obs=seg_obs,
            seg_reward=seg_reward, n_goals=n_goals, high_noise=high_noise,
            low_noise=low_noise, agent=agent, sums=sums,
        )
        traj = {"obs": carry.obs, "next_obs": res.obs, "action": env_action,
                "reward": r_env, "alive": alive, "goal": env.goal_space.select(goal),
                "switch": switch, "duration": duration,
                "intrinsic_reward": jnp.where(alive, r_int, 0.0)}
        return new, traj

    @cached_property
    def relabel_high(self):
        """``(action, step result, key) -> action`` stored in ``D_H``: the action itself, or
        with :class:`~hiddpg.configs.ActionHindsight` the goal reached."""
        return high_relabel(self.config.high_hindsight, self.env.goal_space)

    def _metrics(self, carry: _Carry) -> dict[str, jax.Array]:
        s = carry.sums
        out = {"return": s["ret"], "env_return": s["env_return"], "length": s["length"],
               "switches": jnp.maximum(carry.n_goals - 1, 0).astype(jnp.float32),
               "env_steps": carry.agent.env_steps.astype(jnp.float32)}
        for lv in ("high", "low"):
            n = jnp.maximum(s[f"{lv}_updates"], 1.0)
            for m in _LOSSES:
                out[f"{lv}_{m}"] = s[f"{lv}_{m}"] / n
        return out

    def train_episode(self, key: jax.Array, state: HIDDPGState, env_params: Any):
        carry, _ = self._episode(key, state, env_params, train=True)
        agent = carry.agent.replace(episodes=carry.agent.episodes + 1)
        return agent, self._metrics(carry)

    def evaluate(self, key: jax.Array, state: HIDDPGState, env_params: Any):
        """A noise-free episode without learning: ``(metrics, trajectory)``."""
        carry, traj = self._episode(key, state, env_params, train=False)
        metrics = {k: v for k, v in self._metrics(carry).items() if "loss" not in k}
        return metrics, traj


def step_keys(key: jax.Array) -> dict[str, jax.Array]:
    """One step's random streams by name (:data:`STREAMS`), and the choosers' and the high
    level's hindsight draws derived from them."""
    keys = split_named(key, STREAMS)
    keys["choice_explore"] = jax.random.fold_in(keys["high_random"], 3)
    keys["choice_settle"] = jax.random.fold_in(keys["high_random"], 7)
    keys["high_hindsight"] = jax.random.fold_in(keys["high_update"], 1)
    return keys


def make_hiddpg(config: HIDDPGConfig, env: Environment) -> HIDDPG:
    """HI-DDPG for ``env`` (any :class:`Environment` that declares a ``goal_space``)."""
    if getattr(env, "goal_space", None) is None:
        raise ValueError(f"{env!r} declares no goal_space; HI-DDPG needs one (see GoalSpace)")
    return HIDDPG(config, env)

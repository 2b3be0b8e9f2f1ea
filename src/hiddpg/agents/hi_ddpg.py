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
(:mod:`~hiddpg.agents.intrinsic`), the critics' Huber loss (:mod:`~hiddpg.agents.huber`), more
high-level updates and data (:mod:`~hiddpg.agents.eager`).
"""

from __future__ import annotations

import dataclasses
from functools import cached_property
from typing import Any

import jax
import jax.numpy as jnp

from hiddpg.agents import eager, noise
from hiddpg.agents.block import value_terminal
from hiddpg.agents.choice import Chooser, make_chooser
from hiddpg.agents.episode import decay_factor, run_episode
from hiddpg.agents.hi_ddpg_state import (
    HIDDPGState,
    Segment,
    episode_metrics,
    new_segment,
    step_keys,
    update_sums,
    zero_sums,
)
from hiddpg.agents.hindsight import Hindsight, high_relabel
from hiddpg.agents.intrinsic import IntrinsicReward
from hiddpg.agents.level import Level, LevelState
from hiddpg.agents.transition import Transition
from hiddpg.configs import HIDDPGConfig
from hiddpg.envs.base import Environment, affine_unit


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
        return IntrinsicReward(goal_space=self.env.goal_space, obs_dim=self.env.obs_dim,
                               rest=self.config.rest_term)

    @cached_property
    def low(self) -> Level:
        c, env = self.config, self.env
        hindsight = None
        if c.low_hindsight is not None:
            hindsight = Hindsight(fraction=c.low_hindsight.fraction, goal_space=env.goal_space,
                                  obs_dim=env.obs_dim, reward=self.intrinsic_reward)
        return Level(config=c.low, state_dim=env.obs_dim, context_dim=env.obs_dim,
                     action_dim=env.action_dim, time_scale=float(env.dt),
                     model_weight=c.model_weight, use_model=c.use_model, hindsight=hindsight,
                     model_masked=c.model_masked)

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
        return HIDDPGState(high=self.high.init(k_high), low=self.low.init(k_low),
                           env_steps=zero, episodes=zero)

    # -- Alg. 1 line 7: the high level chooses (g, T), with OU noise -----------------------------
    def choose(self, state: HIDDPGState, seg: Segment, hobs: jax.Array,
               steps_left: jax.Array, keys: dict, noise_eps: jax.Array | None,
               random: jax.Array) -> jax.Array:
        """The unit ``(g, T)`` at a switch; ``noise_eps`` (training) explores it, ``random``
        (random phase or pre-training) replaces it by a uniform draw."""
        high = state.high
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

    # -- one episode (the harness, hiddpg.agents.episode; Alg. 1 lines 3-6) -------------------
    @property
    def learning_starts(self) -> int:
        return self.config.learning_starts

    def step_keys(self, key: jax.Array, train: bool) -> dict[str, jax.Array]:
        return step_keys(key)

    def decay(self, state: HIDDPGState) -> HIDDPGState:
        c = self.config
        factor = decay_factor(c.lr_decay, c.lr_decay_every, state.episodes)
        return state.replace(
            high=self.high.set_learning_rate(state.high, c.high.lr * factor),
            low=self.low.set_learning_rate(state.low, c.low.lr * factor),
        )

    def begin(self, state: HIDDPGState, obs: jax.Array, horizon: int, train: bool):
        """Alg. 1 lines 4-5: new OU processes; no segment yet."""
        c, seg_obs = self.config, self.choice.inputs(obs, jnp.asarray(horizon), horizon)
        return new_segment(obs, seg_obs, self.goal_dim, self.env.action_dim, c.high.noise,
                           c.low.noise), zero_sums()

    def act(self, state: HIDDPGState, seg: Segment, obs: jax.Array, alive: jax.Array,
            keys: dict, random_phase: jax.Array, env_params: Any, horizon: int, train: bool):
        """Alg. 1 lines 7-9: at a switch the high level chooses ``(g, T)``; the low level
        acts on ``[s, g]``."""
        c, choice = self.config, self.choice
        pretrain = state.episodes < c.pretrain_episodes
        switch = alive & (seg.remaining <= 0)
        steps_left = horizon - seg.t
        hobs = choice.inputs(obs, steps_left, horizon)
        high_noise, eps = seg.high_noise, None
        if train:
            new_noise, eps = noise.sample(c.high.noise, high_noise, keys["high_noise"],
                                          state.episodes)
            high_noise = jax.tree.map(lambda a, b: jnp.where(switch, a, b), new_noise, high_noise)
        explore_random = (random_phase | pretrain) if train else jnp.array(False)
        high_action = self.choose(state, seg, hobs, steps_left, keys, eps, explore_random)
        high_action = jnp.where(switch, high_action, seg.high_action)
        goal, duration = self.decode(high_action)
        n = jnp.clip(jnp.round(duration), 1, steps_left).astype(jnp.int32)
        carried = choice.carried(high_action, n)
        first = switch & (seg.n_goals == 0)
        q_start = jnp.where(first, choice.q(state.high, hobs, carried), 0.0)
        seg = seg.replace(
            high_action=jnp.where(switch, carried, high_action),
            goal=goal, remaining=jnp.where(switch, n, seg.remaining),
            seg_obs=jnp.where(switch, hobs, seg.seg_obs),
            seg_reward=jnp.where(switch, 0.0, seg.seg_reward),
            n_goals=seg.n_goals + switch.astype(jnp.int32), high_noise=high_noise)
        action = self.low_policy(state.low, obs, goal, env_params)
        if train:
            action, low_noise = self.low_explore(action, seg.low_noise, keys, random_phase,
                                                 state.episodes)
            seg = seg.replace(low_noise=low_noise)
        env_action = self.env_action(action)
        return seg, env_action, (action, switch, duration, steps_left, pretrain, q_start)

    def observe(self, state: HIDDPGState, seg: Segment, obs: jax.Array, info: Any, res: Any,
                alive: jax.Array, keys: dict, random_phase: jax.Array, horizon: int,
                train: bool):
        """Alg. 1 lines 10-20: the rewards of the step; in training ``D_L`` and ``D_H`` get
        their transitions and both levels learn."""
        c = self.config
        action, switch, duration, steps_left, pretrain, q_start = info
        r_env = jnp.where(alive, res.reward, 0.0)
        done = res.terminated | res.truncated
        r_int = self.intrinsic_reward(res.obs, seg.goal)
        seg_reward = seg.seg_reward + r_env
        seg = seg.replace(remaining=seg.remaining - 1, seg_reward=seg_reward,
                          t=seg.t + alive.astype(jnp.int32))
        seg_end = alive & ((seg.remaining <= 0) | done)
        # line 14: the high level's reward, the switch cost for every goal after the first
        f = seg_reward - c.switch_cost * (seg.n_goals > 1)
        space = self.env.goal_space  # how far each segment ended from its goal
        reach = jnp.linalg.norm(space.select(res.obs) - space.select(seg.goal))
        adds = {"env_return": r_env, "ret": jnp.where(seg_end, f, 0.0), "length": alive,
                "reach_error": jnp.where(seg_end, reach, 0.0), "segments": seg_end,
                "high_q_start": q_start,
                "high_return_discounted": jnp.where(seg_end, seg.discount * f, 0.0)}
        seg = seg.replace(discount=jnp.where(seg_end, seg.discount * c.high.gamma,
                                             seg.discount))
        if train:
            state, learned = self._store_and_learn(state, seg, obs, action, res, r_int, f,
                                                   alive, seg_end, keys, random_phase,
                                                   steps_left, pretrain, horizon)
            adds.update(learned)
        traj = {"obs": obs, "next_obs": res.obs, "action": self.env_action(action),
                "reward": r_env, "alive": alive, "goal": self.env.goal_space.select(seg.goal),
                "switch": switch, "duration": duration,
                "intrinsic_reward": jnp.where(alive, r_int, 0.0)}
        return state, seg, adds, traj

    def _store_and_learn(self, state: HIDDPGState, seg: Segment, obs, action, res, r_int, f,
                         alive, seg_end, keys, random_phase, steps_left, pretrain, horizon):
        c, choice = self.config, self.choice
        low_tr = Transition(
            obs=obs, context=seg.goal, action=action, reward=r_int, next_obs=res.obs,
            terminated=value_terminal(res, c.low.end_is_terminal, c.low.env_terminal),
            **({"episode": state.episodes, "steps_left": steps_left - 1}
               if self.low.hindsight is not None else {}))
        context, act = choice.stored(seg.high_action)
        act = self.relabel_high(act, res, keys["high_hindsight"])
        high_tr = Transition(
            obs=seg.seg_obs, context=context, action=act, reward=f,
            next_obs=choice.inputs(res.obs, steps_left - 1, horizon),
            terminated=value_terminal(res, c.high.end_is_terminal, c.high.env_terminal))
        # lines 11 and 15: D_L every step, D_H at a segment's end
        store_high = eager.stores_segment(c.eager_high, pretrain)
        state = state.replace(low=self.low.store(state.low, low_tr, alive),
                              high=self.high.store(state.high, high_tr, seg_end & store_high))
        # lines 12 and 16-20: one low-level update a step, one high-level update a segment
        started = ~random_phase
        learn_low = alive & started
        high_tick = eager.high_update_due(c.eager_high, seg_end, alive)
        learn_high = (high_tick & started & ~pretrain
                      & (state.high.buffer.size >= c.high_learning_starts))
        low_state, low_m = self.low_update(state.low, keys["low_update"], learn_low,
                                           state.episodes)
        high_state, high_m = choice.update(state.high, keys["high_update"], learn_high,
                                           episode=state.episodes, horizon=horizon)
        state = state.replace(low=low_state, high=high_state,
                              env_steps=state.env_steps + alive.astype(jnp.int32))
        return state, update_sums(high_m, low_m, learn_high, learn_low)

    def finish(self, state: HIDDPGState, seg: Segment, sums: dict, traj: dict, train: bool):
        metrics = episode_metrics(state, seg, sums, train)
        return (state.replace(episodes=state.episodes + 1) if train else state), metrics

    @cached_property
    def relabel_high(self):
        """``(action, step result, key) -> action`` stored in ``D_H``: the action itself, or
        with :class:`~hiddpg.configs.ActionHindsight` the goal reached."""
        return high_relabel(self.config.high_hindsight, self.env.goal_space)

    def train_episode(self, key: jax.Array, state: HIDDPGState, env_params: Any):
        state, metrics, _ = run_episode(self, key, state, env_params, train=True)
        return state, metrics.as_dict()

    def evaluate(self, key: jax.Array, state: HIDDPGState, env_params: Any):
        """A noise-free episode without learning: ``(metrics, trajectory)``."""
        _, metrics, traj = run_episode(self, key, state, env_params, train=False)
        return metrics.as_dict(), traj


def make_hiddpg(config: HIDDPGConfig, env: Environment) -> HIDDPG:
    """HI-DDPG for ``env`` (any :class:`Environment` that declares a ``goal_space``)."""
    if getattr(env, "goal_space", None) is None:
        raise ValueError(f"{env!r} declares no goal_space; HI-DDPG needs one (see GoalSpace)")
    return HIDDPG(config, env)

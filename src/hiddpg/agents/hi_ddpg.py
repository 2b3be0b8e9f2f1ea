"""HI-DDPG: hierarchical intermittent DDPG (paper §II-B/C, Alg. 1; spec §2-3).

The high level chooses, at switch points ``t_i``, a goal ``g`` (the environment's goal entries,
``tanh`` scaled to its goal bounds; other entries 0) and a duration ``T ∈ [T_min, T_max]``;
the low level acts for ``n = clip(round(T), 1, steps left)`` steps on ``[s, g]`` and learns from
the intrinsic reward ``r_int = -|P (s' - g)|``. The high level's reward for segment ``i`` is
``f_i = Σ r_env - c_switch [i > 1]`` (the minimum transition hypothesis).

Under ``jit``/``vmap`` switching is a mask: every step computes the high level's candidate
action and keeps it with ``where(switch, new, old)``; ``D_H`` gets a masked insert and the
high-level update is gated by the segment end. One episode is a ``lax.scan`` over the horizon.
With ``duration_choice="argmax"`` the critic picks the duration and the actor the goal for it
(:mod:`hiddpg.agents.durations`).

Phases (spec §2): the first ``learning_starts`` environment steps use uniformly random goals,
durations and actions; during the first ``pretrain_episodes`` episodes the high level is
bypassed (uniformly random goals and durations) and only the low level learns; ``D_H`` stores
their segments only with ``pretrain_fills_high_buffer`` (their returns were earned by a low
level that has since changed, but they cover the goal space far more broadly than the high
level's own first goals).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import jax
import jax.numpy as jnp
from flax import struct

from hiddpg.agents import durations, noise
from hiddpg.agents.block import value_terminal
from hiddpg.agents.hindsight import Hindsight, reached_action
from hiddpg.agents.hold import hold
from hiddpg.agents.level import Level, LevelState
from hiddpg.configs import HIDDPGConfig
from hiddpg.envs.base import Environment, affine_unit

_LOSSES = ("critic_loss", "actor_loss", "model_loss")


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
    seg_obs: jax.Array  # s_{t_i}
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

    @property
    def goal_dim(self) -> int:
        return self.env.goal_space.dim

    @property
    def high(self) -> Level:
        c = self.config
        if self.argmax:  # context: the duration; action: the goal
            return Level(c.high, self.env.obs_dim + 1, 1, self.goal_dim, 1.0, 0.0, False)
        return Level(c.high, self.env.obs_dim + int(c.high_time_input), 0, self.goal_dim + 1,
                     1.0, c.model_weight, c.use_model)

    @property
    def argmax(self) -> bool:
        """Whether the critic chooses the duration (:mod:`hiddpg.agents.durations`)."""
        return self.config.duration_choice == "argmax"

    @property
    def low(self) -> Level:
        c = self.config
        hindsight = None
        if c.low_hindsight > 0:
            hindsight = Hindsight(c.low_hindsight, self.env.goal_space, self.env.obs_dim,
                                  lambda s2, g, a: self.intrinsic_reward(s2, g,
                                                                         self.env_action(a)))
        return Level(c.low, self.env.obs_dim, self.env.obs_dim, self.env.action_dim,
                     float(self.env.dt), c.model_weight, c.use_model, hindsight)

    # -- the high-level action -------------------------------------------------------------
    def decode(self, high_action: jax.Array) -> tuple[jax.Array, jax.Array]:
        """Unit high-level action → (full goal vector, continuous duration ``T``)."""
        space, c = self.env.goal_space, self.config
        goal = space.embed(space.scale(high_action[: self.goal_dim]), self.env.obs_dim)
        t_unit = high_action[self.goal_dim]
        duration = affine_unit(t_unit, c.duration_min, c.duration_max)
        return goal, duration

    def duration_unit(self, duration: jax.Array) -> jax.Array:
        """Inverse of :meth:`decode`'s duration map: ``T`` → the unit action entry."""
        c = self.config
        return 2.0 * (duration - c.duration_min) / (c.duration_max - c.duration_min) - 1.0

    def high_obs(self, obs: jax.Array, steps_left: jax.Array, horizon: int) -> jax.Array:
        """The high level's input: ``obs``, and with ``high_time_input`` the fraction of the
        episode left, ``steps_left / horizon`` (1 at the start, 0 at the end)."""
        if not self.config.high_time_input:
            return obs
        return jnp.concatenate([obs, (steps_left / horizon)[None].astype(obs.dtype)])

    def high_q(self, state: HIDDPGState, hobs: jax.Array, action: jax.Array) -> jax.Array:
        """The high critic's value of the unit action ``(g, T)`` at input ``hobs``."""
        block, critic = self.high.block, state.high.block.critic
        if self.argmax:
            inputs = jnp.concatenate([hobs, action[self.goal_dim:]], axis=-1)
            return block.q(critic, inputs, action[: self.goal_dim])
        return block.q(critic, hobs, action)

    def _actor_action(self, state: HIDDPGState, hobs: jax.Array,
                      steps_left: jax.Array) -> jax.Array:
        """The actor's noise-free ``(g, T)``; with ``"argmax"`` the critic's best duration
        and the actor's goal for it."""
        if not self.argmax:
            return self.high.act(state.high, hobs, jnp.zeros((0,)))
        block = state.high.block
        tau, goal, _ = durations.best(self, block.actor, block.critic, hobs, steps_left)
        return jnp.concatenate([goal, tau[None]])

    def policy_action(self, state: HIDDPGState, hobs: jax.Array,
                      steps_left: jax.Array) -> jax.Array:
        """The noise-free high-level action at a switch from input ``hobs``
        (:meth:`high_obs`): the actor's, with its goal held to the end where ``hold_choice``
        prefers that — what an evaluation episode does."""
        action = self._actor_action(state, hobs, steps_left)
        if not self.config.hold_choice:
            return action
        return hold(self, state, hobs, action, steps_left, jax.random.PRNGKey(0), False,
                    jnp.array(True))

    def env_action(self, unit: jax.Array) -> jax.Array:
        return affine_unit(unit, self.env.action_low, self.env.action_high)

    def intrinsic_reward(self, next_obs: jax.Array, goal: jax.Array,
                         env_action: jax.Array) -> jax.Array:
        """``r_int = -|P (s' - g)|_2`` (spec §2), or with ``intrinsic_squared`` and
        ``intrinsic_action_cost = w`` the quadratic ``-(|P (s' - g)|^2 + w |a|^2)`` of the
        environment action ``a``."""
        space, c = self.env.goal_space, self.config
        error = space.select(next_obs) - space.select(goal)
        if c.intrinsic_rest_weight > 0:  # the goal's other entries (0: at rest) count too
            rest = jnp.asarray([i for i in range(self.env.obs_dim) if i not in space.indices])
            error = jnp.concatenate([error, c.intrinsic_rest_weight * next_obs[rest]])
        if c.intrinsic_squared:
            distance = jnp.sum(jnp.square(error))
        else:
            distance = jnp.linalg.norm(error)
        if c.intrinsic_action_cost == 0:
            return -distance
        return -(distance + c.intrinsic_action_cost * jnp.sum(jnp.square(env_action)))

    # -- protocol ---------------------------------------------------------------------------
    def init(self, key: jax.Array, env_params: Any) -> HIDDPGState:
        del env_params
        k_high, k_low = jax.random.split(key)
        zero = jnp.zeros((), jnp.int32)
        return HIDDPGState(self.high.init(k_high), self.low.init(k_low), zero, zero)

    def _decay(self, state: HIDDPGState) -> HIDDPGState:
        c = self.config
        factor = c.lr_decay ** (state.episodes // c.lr_decay_every).astype(jnp.float32)
        return state.replace(
            high=self.high.set_learning_rate(state.high, c.high.lr * factor),
            low=self.low.set_learning_rate(state.low, c.low.lr * factor),
        )

    def _episode(self, key: jax.Array, state: HIDDPGState, env_params: Any, train: bool,
                 first: jax.Array | None = None):
        env, horizon = self.env, self.env.max_steps(env_params)
        k_reset, k_steps = jax.random.split(key)
        obs, env_state = env.reset(k_reset, env_params)
        zeros = {f"{lv}_{m}": jnp.zeros(()) for lv in ("high", "low") for m in _LOSSES}
        carry = _Carry(
            env_state=env_state, obs=obs, alive=jnp.array(True),
            high_action=jnp.zeros((self.goal_dim + 1,)), goal=jnp.zeros_like(obs),
            remaining=jnp.zeros((), jnp.int32),
            seg_obs=self.high_obs(obs, jnp.asarray(horizon), horizon), seg_reward=jnp.zeros(()),
            n_goals=jnp.zeros((), jnp.int32),
            high_noise=noise.init(self.config.high.noise, self.goal_dim + 1),
            low_noise=noise.init(self.config.low.noise, env.action_dim),
            agent=self._decay(state) if train else state,
            sums=dict(zeros, high_updates=jnp.zeros(()), low_updates=jnp.zeros(()),
                      env_return=jnp.zeros(()), ret=jnp.zeros(()), length=jnp.zeros(())),
        )
        step = lambda c, k: self._step(c, k, env_params, horizon, train, first)  # noqa: E731
        carry, traj = jax.lax.scan(step, carry, jax.random.split(k_steps, horizon))
        return carry, traj

    def _step(self, carry: _Carry, key: jax.Array, env_params: Any, horizon: int, train: bool,
              first: jax.Array | None = None):
        c, env, high, low = self.config, self.env, self.high, self.low
        keys = jax.random.split(key, 7)
        agent = carry.agent
        # 1. switch: the high level picks a new goal and duration (Alg. 1 line 7)
        switch = carry.alive & (carry.remaining <= 0)
        steps_left = horizon - carry.env_state.t
        hobs = self.high_obs(carry.obs, steps_left, horizon)
        high_action = self._actor_action(agent, hobs, steps_left)
        high_noise, low_noise = carry.high_noise, carry.low_noise
        random_phase = pretrain = jnp.array(False)
        if train:
            new_noise, eps = noise.sample(c.high.noise, high_noise, keys[0], agent.episodes)
            high_noise = jax.tree.map(lambda a, b: jnp.where(switch, a, b), new_noise, high_noise)
            random_phase = agent.env_steps < c.learning_starts
            pretrain = agent.episodes < c.pretrain_episodes
            if c.duration_explore > 0:
                high_action = durations.explore(self, agent.high, hobs, high_action,
                                                steps_left, keys[1])
            if self.argmax:  # the duration is a choice, not a noisy output
                eps = eps.at[self.goal_dim].set(0.0)
            uniform = jax.random.uniform(keys[1], high_action.shape, minval=-1.0, maxval=1.0)
            high_action = jnp.where(random_phase | pretrain, uniform,
                                    jnp.clip(high_action + eps, -1.0, 1.0))
        if c.hold_choice or (train and c.hold_explore > 0):
            high_action = hold(self, agent, hobs, high_action, steps_left, keys[1], train,
                               ~(random_phase | pretrain))
        if first is not None:  # a given first high-level action (evaluate's probe)
            high_action = jnp.where(carry.n_goals == 0, first, high_action)
        high_action = jnp.where(switch, high_action, carry.high_action)
        goal, duration = self.decode(high_action)
        n = jnp.clip(jnp.round(duration), 1, steps_left).astype(jnp.int32)
        if self.argmax:  # D_H stores the duration carried out
            carried = high_action.at[self.goal_dim].set(self.duration_unit(n.astype(jnp.float32)))
            high_action = jnp.where(switch, carried, high_action)
        remaining = jnp.where(switch, n, carry.remaining)
        seg_obs = jnp.where(switch, hobs, carry.seg_obs)
        seg_reward = jnp.where(switch, 0.0, carry.seg_reward)
        n_goals = carry.n_goals + switch.astype(jnp.int32)
        # 2. the low level acts on [s, g] (Alg. 1 lines 9-10)
        learned_low = c.low_controller == "learned"
        if learned_low:
            action = low.act(agent.low, carry.obs, goal)
        else:  # the environment's own controller (a diagnostic: the low level is not learned)
            action = env.reference_controller(carry.obs, goal, env_params)
        if train and learned_low:
            low_noise, eps = noise.sample(c.low.noise, low_noise, keys[2], agent.episodes)
            uniform = jax.random.uniform(keys[3], action.shape, minval=-1.0, maxval=1.0)
            action = jnp.where(random_phase, uniform, jnp.clip(action + eps, -1.0, 1.0))
        env_action = self.env_action(action)
        res = env.step(keys[4], carry.env_state, env_action, env_params)
        alive = carry.alive
        r_env = jnp.where(alive, res.reward, 0.0)
        done = res.terminated | res.truncated
        r_int = self.intrinsic_reward(res.obs, goal, env_action)
        remaining = remaining - 1
        seg_reward = seg_reward + r_env
        seg_end = alive & ((remaining <= 0) | done)
        f = seg_reward - c.switch_cost * (n_goals > 1)
        sums = dict(carry.sums)
        if train:  # 3. store and learn (Alg. 1 lines 11-12 and 14-20)
            low_tr = {"s": carry.obs, "c": goal, "a": action, "r": r_int, "s2": res.obs,
                      "terminated": value_terminal(res, c.low.end_is_terminal,
                                                  c.low.env_terminal)}
            if c.low_hindsight > 0:  # where in the episode (agents/hindsight.py)
                low_tr.update(ep=agent.episodes, left=steps_left - 1)
            gd = self.goal_dim
            context, act = ((high_action[gd:], high_action[:gd]) if self.argmax
                            else (jnp.zeros((0,)), high_action))
            if c.high_hindsight > 0:  # the goal reached instead of the goal set, but a
                # collision stays charged to the goal asked for
                use = jax.random.uniform(jax.random.fold_in(keys[6], 1)) < c.high_hindsight
                use = use & ~res.terminated
                act = reached_action(env.goal_space, act, res.obs, use)
            r_high = f
            if c.high.terminal_head:  # (r_run, r_term): the terminating step's reward apart
                r_term = jnp.where(res.terminated, r_env, 0.0)
                r_high = jnp.stack([f - r_term, r_term])
            high_tr = {"s": seg_obs, "c": context, "a": act, "r": r_high,
                       "s2": self.high_obs(res.obs, steps_left - 1, horizon),
                       "terminated": value_terminal(res, c.high.end_is_terminal,
                                                    c.high.env_terminal)}
            store_high = ~pretrain | c.pretrain_fills_high_buffer
            agent = agent.replace(low=low.store(agent.low, low_tr, alive),
                                  high=high.store(agent.high, high_tr, seg_end & store_high))
            started = agent.env_steps >= c.learning_starts
            learn_low = alive & started & learned_low
            high_tick = seg_end if c.high_update_on == "segment" else alive
            learn_high = (high_tick & started & ~pretrain
                          & (agent.high.buffer.size >= c.high_learning_starts))
            low_state, low_m = low.maybe_update(agent.low, keys[5], learn_low,
                                                episode=agent.episodes)
            hooks = ((durations.next_value(self, horizon), durations.actor_inputs(self, horizon))
                     if self.argmax else (None, None))
            high_state, high_m = high.maybe_update(agent.high, keys[6], learn_high, *hooks,
                                                  episode=agent.episodes)
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

    def evaluate(self, key: jax.Array, state: HIDDPGState, env_params: Any,
                 first: jax.Array | None = None):
        """A noise-free episode; ``first`` (a unit high-level action), if given, replaces the
        high level's first choice (:mod:`hiddpg.experiments.probes`)."""
        carry, traj = self._episode(key, state, env_params, train=False, first=first)
        metrics = {k: v for k, v in self._metrics(carry).items() if "loss" not in k}
        return metrics, traj


def make_hiddpg(config: HIDDPGConfig, env: Environment) -> HIDDPG:
    """HI-DDPG for ``env`` (any :class:`Environment` that declares a ``goal_space``)."""
    if getattr(env, "goal_space", None) is None:
        raise ValueError(f"{env!r} declares no goal_space; HI-DDPG needs one (see GoalSpace)")
    if config.low_controller == "reference" and not hasattr(env, "reference_controller"):
        raise ValueError(f"low_controller='reference' needs an environment with a "
                         f"reference_controller (the PuckWorld tasks); {env!r} has none: "
                         "use low_controller='learned'")
    return HIDDPG(config, env)

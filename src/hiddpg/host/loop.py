"""One episode of every seed with the environments stepped on the host: the harness of
:mod:`hiddpg.agents.episode` unrolled into a Python loop around the same agent hooks.

Per step, for all seeds at once: a jitted ``act`` (the agent's :meth:`act`), the vector
environment's ``step`` on the host, a jitted ``observe`` (the agent's :meth:`observe`: rewards,
storing and learning, the per-step sums and the trajectory). What the JAX harness does is kept:

* the same random streams: an episode key splits into the reset key and the horizon's step
  keys, each step's keys come from the agent's ``step_keys``; the reset key becomes the
  Gymnasium reset seed (``reset(seed=...)`` at every episode's start), so an episode depends
  only on its key: a seed's run does not depend on the other seeds, and a resumed run needs
  no environment state from its checkpoint;
* episodes in lock step: a seed whose episode ended is masked (``alive`` false: nothing stored,
  learned or counted, observation frozen) until every seed's episode has ended or the horizon
  is reached; its environment, reset by Gymnasium's ``NEXT_STEP`` autoreset, steps on unseen;
* Gymnasium's ``terminated`` and ``truncated`` reach the agents as they are (a terminated
  transition does not bootstrap, a truncated one does unless the config says otherwise).

Steps after every seed's episode ended are not run: their trajectory entries are 0 (``alive``
0), where the JAX harness repeats the frozen state. Seeds are batched as the JAX engine batches
them: one ``vmap`` on accelerators, one after another on CPU (:func:`seed_groups`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from hiddpg.agents.gate import SEED_AXIS
from hiddpg.devices import batch_seeds
from hiddpg.envs.base import StepResult
from hiddpg.host.env import HostEnv


@struct.dataclass
class StepCarry:
    """One seed's episode between two steps (the JAX harness's scan carry, plus what the scan
    itself held: the step keys, the step index and the trajectory written so far)."""

    agent: Any
    inner: Any
    obs: jax.Array
    alive: jax.Array
    sums: dict
    traj: dict
    keys: jax.Array
    t: jax.Array


def seed_groups(n_seeds: int) -> list[slice]:
    """How the host loop batches ``n_seeds`` seeds: one group of all of them, a ``vmap``
    (accelerators), or one group per seed (CPU, where :func:`hiddpg.devices.batch_seeds` says
    that seeds run one after another: each seed then computes exactly what it computes alone,
    and its replay buffers are updated in place, never sliced out of a stacked array)."""
    if batch_seeds():
        return [slice(0, n_seeds)]
    return [slice(i, i + 1) for i in range(n_seeds)]


def split(tree: Any, groups: list[slice]) -> list[Any]:
    """A pytree with a leading seed axis as one pytree per group."""
    return [jax.tree.map(lambda x, g=g: x[g], tree) for g in groups]


def merge(trees: list[Any]) -> Any:
    """Inverse of :func:`split`."""
    if len(trees) == 1:
        return trees[0]
    return jax.tree.map(lambda *xs: jnp.concatenate(xs), *trees)


def over_seeds(fn: Callable[..., Any]) -> Callable[..., Any]:
    """``fn`` (one seed) applied to arguments with a leading axis of a group's seeds: one seed
    plainly, several as a ``vmap`` named :data:`SEED_AXIS` (so that skipped updates stay real
    branches, :func:`hiddpg.agents.gate.gated`)."""

    def batched(*args: Any) -> Any:
        if jax.tree.leaves(args)[0].shape[0] == 1:
            out = fn(*jax.tree.map(lambda x: x[0], args))
            return jax.tree.map(lambda x: x[None], out)
        return jax.vmap(fn, axis_name=SEED_AXIS)(*args)

    return batched


class HostEpisodes:
    """Training (``train=True``) or evaluation episodes of ``agent`` on ``env``, every seed of
    a vector environment at once (see module docstring)."""

    def __init__(self, agent: Any, env: HostEnv, train: bool) -> None:
        self.agent, self.env, self.train = agent, env, train
        self.horizon = env.horizon
        self._seeds = jax.jit(over_seeds(self._reset_seed))
        self._begin = jax.jit(over_seeds(self._begin_one))
        self._act = jax.jit(over_seeds(self._act_one))
        self._observe = jax.jit(over_seeds(self._observe_one), donate_argnums=(0, 1))
        self._finish = jax.jit(over_seeds(self._finish_one))

    # -- one seed, pure --------------------------------------------------------------------
    @staticmethod
    def _reset_seed(key: jax.Array) -> jax.Array:
        k_reset, _ = jax.random.split(key)
        return jax.random.bits(k_reset, (), jnp.uint32)

    def _begin_one(self, state: Any, key: jax.Array, obs: jax.Array) -> StepCarry:
        _, k_steps = jax.random.split(key)
        obs = jnp.asarray(obs, jnp.float32)
        if self.train:
            state = self.agent.decay(state)
        inner, sums = self.agent.begin(state, obs, self.horizon, self.train)
        carry = StepCarry(agent=state, inner=inner, obs=obs, alive=jnp.ones((), bool),
                          sums=sums, traj={}, keys=jax.random.split(k_steps, self.horizon),
                          t=jnp.zeros((), jnp.int32))
        shapes = jax.eval_shape(self._out, carry)
        traj = jax.tree.map(lambda s: jnp.zeros((self.horizon,) + s.shape, s.dtype), shapes)
        return carry.replace(traj=traj)

    def _streams(self, c: StepCarry) -> tuple[dict, jax.Array]:
        keys = self.agent.step_keys(c.keys[c.t], self.train)
        return keys, c.agent.env_steps < self.agent.learning_starts

    def _act_one(self, c: StepCarry) -> tuple[Any, jax.Array, Any]:
        keys, random_phase = self._streams(c)
        return self.agent.act(c.agent, c.inner, c.obs, c.alive, keys, random_phase,
                              self.env.params, self.horizon, self.train)

    def _observe_one(self, c: StepCarry, inner: Any, info: Any, next_obs: jax.Array,
                     reward: jax.Array, terminated: jax.Array,
                     truncated: jax.Array) -> StepCarry:
        keys, random_phase = self._streams(c)
        res = StepResult(obs=next_obs, state=None, reward=reward, terminated=terminated,
                         truncated=truncated, info={})
        state, inner, adds, out = self.agent.observe(c.agent, inner, c.obs, info, res, c.alive,
                                                     keys, random_phase, self.horizon,
                                                     self.train)
        sums = {k: v + adds[k] if k in adds else v for k, v in c.sums.items()}
        traj = jax.tree.map(lambda buf, x: buf.at[c.t].set(x), c.traj, out)
        return StepCarry(agent=state, inner=inner, obs=jnp.where(c.alive, next_obs, c.obs),
                         alive=c.alive & ~(terminated | truncated), sums=sums, traj=traj,
                         keys=c.keys, t=c.t + 1)

    def _out(self, c: StepCarry) -> dict:
        """A step's trajectory entries (traced for their shapes only)."""
        inner, action, info = self._act_one(c)
        f0, no = jnp.zeros((), jnp.float32), jnp.zeros((), bool)
        res = StepResult(obs=c.obs, state=None, reward=f0, terminated=no, truncated=no, info={})
        keys, random_phase = self._streams(c)
        return self.agent.observe(c.agent, inner, c.obs, info, res, c.alive, keys,
                                  random_phase, self.horizon, self.train)[3]

    def _finish_one(self, c: StepCarry) -> tuple[Any, dict, dict]:
        state, metrics = self.agent.finish(c.agent, c.inner, c.sums, c.traj, self.train)
        return state, metrics.as_dict(), c.traj

    # -- every seed, on the host -----------------------------------------------------------
    def run(self, states: list[Any], keys: list[jax.Array], vec: Any
            ) -> tuple[list[Any], list[dict], list[dict]]:
        """One episode per seed in the vector environment ``vec`` (one environment per seed):
        ``states`` and the episode keys ``keys`` are given per group of seeds
        (:func:`seed_groups`, in the order of ``vec``'s environments), and so are the
        returned states, metrics and trajectories (axes seed, horizon, ...)."""
        seeds = np.concatenate([np.asarray(self._seeds(k)) for k in keys])
        obs, _ = vec.reset(seed=[int(s) for s in seeds])
        bounds = np.cumsum([0] + [len(k) for k in keys])
        parts = list(zip(bounds[:-1], bounds[1:], strict=True))
        obs = np.asarray(obs, np.float32)
        carries = [self._begin(s, k, obs[a:b])
                   for s, k, (a, b) in zip(states, keys, parts, strict=True)]
        alive = np.ones(len(seeds), bool)
        for _ in range(self.horizon):
            acted = [self._act(c) for c in carries]  # dispatched for every group, then read
            action = np.concatenate([np.asarray(a) for _, a, _ in acted])
            obs, reward, terminated, truncated, _ = vec.step(self.env.to_box(action))
            obs, reward = np.asarray(obs, np.float32), np.asarray(reward, np.float32)
            terminated, truncated = np.asarray(terminated, bool), np.asarray(truncated, bool)
            carries = [self._observe(c, inner, info, obs[a:b], reward[a:b], terminated[a:b],
                                     truncated[a:b])
                       for c, (inner, _, info), (a, b) in zip(carries, acted, parts,
                                                              strict=True)]
            alive &= ~(terminated | truncated)
            if not alive.any():
                break
        done = [self._finish(c) for c in carries]
        return [d[0] for d in done], [d[1] for d in done], [d[2] for d in done]

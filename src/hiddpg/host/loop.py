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

The replay buffers are the largest part of an agent's state and must never be copied per step.
A seed that is a group of its own therefore enters the compiled steps with its own arrays, the
seed axis stripped once per chunk (:func:`split`), and training donates the agent's state to
every call that returns it (``begin``, ``observe``, ``finish``), so that XLA updates the
buffers in place; evaluation only reads the state and returns none of it.
"""

from __future__ import annotations

import dataclasses
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
    """One seed's episode between two steps, less the agent's state (the JAX harness's scan
    carry, plus what the scan itself held: the step keys, the step index and the trajectory
    written so far). The agent's state travels apart: training donates it to every step,
    evaluation only reads it."""

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
    that seeds run one after another: each seed then computes exactly what it computes
    alone)."""
    if batch_seeds():
        return [slice(0, n_seeds)]
    return [slice(i, i + 1) for i in range(n_seeds)]


def one_seed(group: slice) -> bool:
    """Whether ``group`` holds one seed: its arrays then have no seed axis (:func:`split`)."""
    return group.stop - group.start == 1


def split(tree: Any, groups: list[slice]) -> list[Any]:
    """A pytree with a leading seed axis as one pytree per group, in the group's form: a seed
    of its own without the seed axis, several seeds with it (copies, never the input's arrays,
    since the training steps donate them).

    The axis is stripped here, once, rather than inside every compiled step: a step whose
    arrays are the seed's own updates its donated replay buffers in place, where slicing the
    seed out and stacking it back inside the step copies them."""
    return [jax.tree.map(lambda x, g=g: x[g.start] if one_seed(g) else jnp.copy(x[g]), tree)
            for g in groups]


def merge(trees: list[Any], groups: list[slice]) -> Any:
    """Inverse of :func:`split`: one pytree with the leading seed axis."""
    if len(trees) == 1 and not one_seed(groups[0]):
        return trees[0]
    if all(one_seed(g) for g in groups):
        return jax.tree.map(lambda *xs: jnp.stack(xs), *trees)
    return jax.tree.map(lambda *xs: jnp.concatenate(
        [x[None] if one_seed(g) else x for x, g in zip(xs, groups, strict=True)]), *trees)


def over_group(fn: Callable[..., Any], one: bool) -> Callable[..., Any]:
    """``fn`` (one seed) for a group in its :func:`split` form: ``fn`` itself for a group of
    one seed (``one``), a ``vmap`` named :data:`SEED_AXIS` for several (so that skipped
    updates stay real branches, :func:`hiddpg.agents.gate.gated`)."""
    return fn if one else jax.vmap(fn, axis_name=SEED_AXIS)


def to_host(x: Any, group: slice) -> np.ndarray:
    """A group's per-seed array as numpy with the seed axis."""
    x = np.asarray(x)
    return x[None] if one_seed(group) else x


def unchanged(before: Any, after: Any, hook: str) -> None:
    """Raise at trace time if an evaluation hook returned a changed agent state: evaluation
    passes the state by reference and keeps no copy (the JAX engine discards it too)."""
    if not all(a is b for a, b in zip(jax.tree.leaves(before), jax.tree.leaves(after),
                                      strict=True)):
        raise ValueError(f"the agent's {hook} changed its state in evaluation")


@dataclasses.dataclass(frozen=True)
class Steps:
    """The compiled steps of one group form (one seed, or a ``vmap`` of several)."""

    seeds: Callable[..., Any]
    begin: Callable[..., Any]
    act: Callable[..., Any]
    observe: Callable[..., Any]
    finish: Callable[..., Any]


class HostEpisodes:
    """Training (``train=True``) or evaluation episodes of ``agent`` on ``env``, every seed of
    a vector environment at once (see module docstring)."""

    def __init__(self, agent: Any, env: HostEnv, train: bool) -> None:
        self.agent, self.env, self.train = agent, env, train
        self.horizon = env.horizon
        self._steps: dict[bool, Steps] = {}  # by one_seed(group)

    def steps(self, group: slice) -> Steps:
        """The compiled steps for ``group``'s form (built once per form). Training donates
        the agent's state to ``begin``, ``observe`` and ``finish``, so that the replay buffers
        are updated in place and never copied; evaluation donates only the step carry to
        ``observe``."""
        one = one_seed(group)
        if one not in self._steps:
            def jit(fn: Callable[..., Any], donate: tuple[int, ...] = ()) -> Any:
                return jax.jit(over_group(fn, one), donate_argnums=donate)

            agent = (0,) if self.train else ()
            self._steps[one] = Steps(
                seeds=jit(self._reset_seed), begin=jit(self._begin_one, agent),
                act=jit(self._act_one), observe=jit(self._observe_one, agent + (1, 2)),
                finish=jit(self._finish_one, agent))
        return self._steps[one]

    # -- one seed, pure --------------------------------------------------------------------
    @staticmethod
    def _reset_seed(key: jax.Array) -> jax.Array:
        k_reset, _ = jax.random.split(key)
        return jax.random.bits(k_reset, (), jnp.uint32)

    def _begin_one(self, state: Any, key: jax.Array, obs: jax.Array) -> tuple[Any, StepCarry]:
        _, k_steps = jax.random.split(key)
        obs = jnp.asarray(obs, jnp.float32)
        if self.train:
            state = self.agent.decay(state)
        inner, sums = self.agent.begin(state, obs, self.horizon, self.train)
        carry = StepCarry(inner=inner, obs=obs, alive=jnp.ones((), bool), sums=sums, traj={},
                          keys=jax.random.split(k_steps, self.horizon),
                          t=jnp.zeros((), jnp.int32))
        shapes = jax.eval_shape(self._out, state, carry)
        traj = jax.tree.map(lambda s: jnp.zeros((self.horizon,) + s.shape, s.dtype), shapes)
        return (state if self.train else None), carry.replace(traj=traj)

    def _streams(self, state: Any, c: StepCarry) -> tuple[dict, jax.Array]:
        keys = self.agent.step_keys(c.keys[c.t], self.train)
        return keys, state.env_steps < self.agent.learning_starts

    def _act_one(self, state: Any, c: StepCarry) -> tuple[Any, jax.Array, Any]:
        keys, random_phase = self._streams(state, c)
        return self.agent.act(state, c.inner, c.obs, c.alive, keys, random_phase,
                              self.env.params, self.horizon, self.train)

    def _observe_one(self, state: Any, c: StepCarry, inner: Any, info: Any,
                     next_obs: jax.Array, reward: jax.Array, terminated: jax.Array,
                     truncated: jax.Array) -> tuple[Any, StepCarry]:
        keys, random_phase = self._streams(state, c)
        res = StepResult(obs=next_obs, state=None, reward=reward, terminated=terminated,
                         truncated=truncated, info={})
        new, inner, adds, out = self.agent.observe(state, inner, c.obs, info, res, c.alive,
                                                   keys, random_phase, self.horizon,
                                                   self.train)
        sums = {k: v + adds[k] if k in adds else v for k, v in c.sums.items()}
        traj = jax.tree.map(lambda buf, x: buf.at[c.t].set(x), c.traj, out)
        carry = StepCarry(inner=inner, obs=jnp.where(c.alive, next_obs, c.obs),
                          alive=c.alive & ~(terminated | truncated), sums=sums, traj=traj,
                          keys=c.keys, t=c.t + 1)
        return self._kept(state, new, "observe"), carry

    def _out(self, state: Any, c: StepCarry) -> dict:
        """A step's trajectory entries (traced for their shapes only)."""
        inner, action, info = self._act_one(state, c)
        f0, no = jnp.zeros((), jnp.float32), jnp.zeros((), bool)
        res = StepResult(obs=c.obs, state=None, reward=f0, terminated=no, truncated=no, info={})
        keys, random_phase = self._streams(state, c)
        return self.agent.observe(state, inner, c.obs, info, res, c.alive, keys,
                                  random_phase, self.horizon, self.train)[3]

    def _finish_one(self, state: Any, c: StepCarry) -> tuple[Any, dict, dict]:
        new, metrics = self.agent.finish(state, c.inner, c.sums, c.traj, self.train)
        return self._kept(state, new, "finish"), metrics.as_dict(), c.traj

    def _kept(self, state: Any, new: Any, hook: str) -> Any:
        """What a step returns of the agent's state: the new one in training; nothing in
        evaluation, where the state must not change (:func:`unchanged`)."""
        if self.train:
            return new
        unchanged(state, new, hook)
        return None

    # -- every seed, on the host -----------------------------------------------------------
    def run(self, states: list[Any], keys: list[jax.Array], vec: Any, groups: list[slice]
            ) -> tuple[list[Any], list[dict], list[dict]]:
        """One episode per seed in the vector environment ``vec`` (one environment per seed):
        ``states`` and the episode keys ``keys`` are given per group of seeds ``groups``
        (:func:`seed_groups`, in the order of ``vec``'s environments) in their :func:`split`
        form, and so are the returned states, metrics and trajectories (axes seed, horizon,
        ...). Training donates ``states`` (do not use them afterwards); evaluation returns
        them as they are."""
        steps = [self.steps(g) for g in groups]
        seeds = np.concatenate([to_host(s.seeds(k), g)
                                for s, k, g in zip(steps, keys, groups, strict=True)])
        obs, _ = vec.reset(seed=[int(s) for s in seeds])
        obs = np.asarray(obs, np.float32)
        cut = [g.start if one_seed(g) else g for g in groups]  # a group's rows, in its form
        begun = [s.begin(a, k, obs[i]) for s, a, k, i in zip(steps, states, keys, cut,
                                                             strict=True)]
        states = [self._state(a, b[0]) for a, b in zip(states, begun, strict=True)]
        carries = [b[1] for b in begun]
        alive = np.ones(len(seeds), bool)
        for _ in range(self.horizon):
            acted = [s.act(a, c) for s, a, c in zip(steps, states, carries, strict=True)]
            action = np.concatenate([to_host(a, g) for (_, a, _), g in zip(acted, groups,
                                                                            strict=True)])
            obs, reward, terminated, truncated, _ = vec.step(self.env.to_box(action))
            obs, reward = np.asarray(obs, np.float32), np.asarray(reward, np.float32)
            terminated, truncated = np.asarray(terminated, bool), np.asarray(truncated, bool)
            observed = [s.observe(a, c, inner, info, obs[i], reward[i], terminated[i],
                                  truncated[i])
                        for s, a, c, (inner, _, info), i in zip(steps, states, carries, acted,
                                                                cut, strict=True)]
            states = [self._state(a, o[0]) for a, o in zip(states, observed, strict=True)]
            carries = [o[1] for o in observed]
            alive &= ~(terminated | truncated)
            if not alive.any():
                break
        done = [s.finish(a, c) for s, a, c in zip(steps, states, carries, strict=True)]
        return ([self._state(a, d[0]) for a, d in zip(states, done, strict=True)],
                [d[1] for d in done], [d[2] for d in done])

    def _state(self, old: Any, new: Any) -> Any:
        """The agent's state after a step: ``new`` in training, ``old`` in evaluation."""
        return new if self.train else old

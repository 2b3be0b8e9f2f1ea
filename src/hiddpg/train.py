"""The training engine shared by every agent: one run is a jitted scan, seeds are a vmap.

``make_train(config)`` returns a pure ``train(key) -> (state, metrics)`` (PureJaxRL style) and
:class:`Trainer` offers the same computation in chunks for the shell (progress bars,
checkpoints, resume). Both go through :meth:`Trainer.run_chunk`, so one seed and fifteen seeds,
one chunk and many, take the same code path:

* a chunk is ``chunk_episodes`` episodes: an outer ``lax.scan`` over evaluation blocks of
  ``eval_every`` training episodes followed by one noise-free evaluation episode;
* seeds are a leading axis on the run state (:meth:`Trainer.init_seeds`), sharded over the
  devices (one CPU device per core under the ``hiddpg`` command) and, on each device, run one
  after another (CPU) or as a ``vmap`` named :data:`~hiddpg.agents.gate.SEED_AXIS` so that
  skipped updates stay real branches (accelerators); see :mod:`hiddpg.devices`.

The engine knows nothing about an agent's inside (see :mod:`hiddpg.agents.base`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from functools import partial
from typing import Any

import jax
import jax.numpy as jnp
from flax import struct
from jax.sharding import PartitionSpec

from hiddpg.agents import make_agent
from hiddpg.agents.gate import SEED_AXIS
from hiddpg.configs import TrainConfig
from hiddpg.devices import DEVICE_AXIS, batch_seeds, padding, seed_mesh
from hiddpg.envs import make as make_env


@struct.dataclass
class RunState:
    """Everything a run needs to continue: the agent's state, the key, episodes done."""

    agent: Any
    key: jax.Array
    episode: jax.Array


def seed_keys(seeds: list[int] | tuple[int, ...]) -> jax.Array:
    """One PRNG key per seed (seed ``i`` always gets ``PRNGKey(i)``)."""
    return jnp.stack([jax.random.PRNGKey(int(s)) for s in seeds])


def eval_keys(key: int, seeds: Sequence[int]) -> jax.Array:
    """One evaluation key per seed, ``fold_in(PRNGKey(key), seed)``: independent of which
    other seeds are in the run."""
    base = jax.random.PRNGKey(key)
    return jnp.stack([jax.random.fold_in(base, int(s)) for s in seeds])


@dataclasses.dataclass(frozen=True, eq=False)
class Trainer:
    """Builds env and agent from a :class:`TrainConfig` and runs episodes in jitted chunks."""

    config: TrainConfig
    override: Callable[[Any], Any] | None = None
    """``agent -> agent``: replaces the agent the config builds (a diagnostic's policy
    override, :mod:`hiddpg.experiments.overrides`); None trains the config's agent."""

    def __post_init__(self) -> None:
        env, env_params = make_env(self.config.task, **self.config.env_overrides)
        object.__setattr__(self, "env", env)
        object.__setattr__(self, "env_params", env_params)
        agent = make_agent(self.config.algo, self.config.agent, env)
        if self.override is not None:
            agent = self.override(agent)
        object.__setattr__(self, "agent", agent)

    # -- pure, per seed ----------------------------------------------------------------------
    def init(self, key: jax.Array) -> RunState:
        key, init_key = jax.random.split(key)
        agent_state = self.agent.init(init_key, self.env_params)
        return RunState(agent=agent_state, key=key, episode=jnp.zeros((), jnp.int32))

    def _train_block(self, state: RunState, n_train: int) -> tuple[RunState, dict, dict]:
        """``n_train`` training episodes, then one evaluation episode."""

        def episode(carry: RunState, _: Any) -> tuple[RunState, dict]:
            key, ep_key = jax.random.split(carry.key)
            agent_state, metrics = self.agent.train_episode(ep_key, carry.agent, self.env_params)
            metrics = dict(metrics, episode=carry.episode + 1)
            return RunState(agent_state, key, carry.episode + 1), metrics

        state, train_metrics = jax.lax.scan(episode, state, None, length=n_train)
        key, eval_key = jax.random.split(state.key)
        eval_metrics, _ = self.agent.evaluate(eval_key, state.agent, self.env_params)
        eval_metrics = dict(eval_metrics, episode=state.episode)
        return state.replace(key=key), train_metrics, eval_metrics

    def run_chunk(self, state: RunState, n_episodes: int) -> tuple[RunState, dict, dict]:
        """Train ``n_episodes`` (a multiple of ``eval_every``, or fewer than it at the end).

        Returns the new state, training metrics with a leading episode axis and evaluation
        metrics with a leading axis of evaluations.
        """
        every = min(self.config.eval_every, n_episodes)
        if n_episodes % every:
            raise ValueError(
                f"a chunk of {n_episodes} episodes is not a multiple of eval_every={every}"
            )

        def block(carry: RunState, _: Any) -> tuple[RunState, tuple[dict, dict]]:
            carry, train_m, eval_m = self._train_block(carry, every)
            return carry, (train_m, eval_m)

        state, (train_m, eval_m) = jax.lax.scan(block, state, None, length=n_episodes // every)
        train_m = jax.tree.map(lambda x: x.reshape((n_episodes,) + x.shape[2:]), train_m)
        return state, train_m, eval_m

    # -- batched over seeds, jitted ----------------------------------------------------------
    @partial(jax.jit, static_argnums=0)
    def init_seeds(self, keys: jax.Array) -> RunState:
        return jax.vmap(self.init)(keys)

    @partial(jax.jit, static_argnums=(0, 2), donate_argnums=1)
    def run_chunk_seeds(self, state: RunState, n_episodes: int) -> tuple[RunState, dict, dict]:
        """:meth:`run_chunk` for every seed of ``state`` (leading axis).

        Seeds are spread over the devices of :func:`hiddpg.devices.seed_mesh` (padding seeds
        repeat the last one and are dropped); on each device they are batched as
        :func:`hiddpg.devices.batch_seeds` says: one after another (``lax.map``, CPU) or
        ``vmap`` named :data:`SEED_AXIS` (accelerators).
        """
        n_seeds = jax.tree.leaves(state)[0].shape[0]
        run = partial(self.run_chunk, n_episodes=n_episodes)
        if n_seeds == 1:
            return jax.tree.map(lambda x: x[None], run(jax.tree.map(lambda x: x[0], state)))
        if batch_seeds():
            per_device = jax.vmap(run, axis_name=SEED_AXIS)
        else:
            per_device = partial(jax.lax.map, run)
        mesh = seed_mesh(n_seeds)
        if mesh is None:
            return per_device(state)
        pad = padding(n_seeds, mesh.size)
        if pad:
            state = jax.tree.map(
                lambda x: jnp.concatenate([x, jnp.repeat(x[-1:], pad, axis=0)]), state)
        spec = PartitionSpec(DEVICE_AXIS)
        out = jax.shard_map(per_device, mesh=mesh, in_specs=spec, out_specs=spec,
                            check_vma=False)(state)
        return jax.tree.map(lambda x: x[:n_seeds], out) if pad else out

    @partial(jax.jit, static_argnums=0)
    def evaluate_seeds(self, state: RunState, keys: jax.Array) -> tuple[dict, dict]:
        """Noise-free evaluation episode per seed, with trajectories (for plots and GIFs)."""
        return jax.vmap(lambda a, k: self.agent.evaluate(k, a, self.env_params))(state.agent, keys)

    def chunk_sizes(self, done: int = 0) -> list[int]:
        """The chunk lengths that take a run from ``done`` episodes to ``config.episodes``.

        Chunks are multiples of ``eval_every`` so that evaluations fall on the same episodes
        however a run is cut; the boundaries depend only on the config, so a resumed run
        executes exactly the chunks an uninterrupted one would.
        """
        cfg = self.config
        chunk = max(cfg.eval_every, cfg.chunk_episodes // cfg.eval_every * cfg.eval_every)
        sizes, start = [], 0
        while start < cfg.episodes:
            n = min(chunk, cfg.episodes - start)
            if n > cfg.eval_every and n % cfg.eval_every:
                n -= n % cfg.eval_every
            sizes.append(n)
            start += n
        bounds = [0]
        for n in sizes:
            bounds.append(bounds[-1] + n)
        if done in bounds:
            return sizes[bounds.index(done):]
        if done % cfg.eval_every or done > cfg.episodes:
            raise ValueError(f"{done} episodes done is not a chunk boundary of this config "
                             f"(nor a multiple of eval_every={cfg.eval_every} within its "
                             f"{cfg.episodes} episodes)")
        # A finished run extended with ``--resume --episodes N``: its last chunk ended where
        # this config has none. Run up to the next boundary, then this config's chunks.
        nxt = next(b for b in bounds if b > done)
        return [nxt - done] + sizes[bounds.index(nxt):]


def make_train(config: TrainConfig):
    """``train(key) -> (RunState, train_metrics, eval_metrics)`` for one seed, pure and
    jittable: ``jax.jit(jax.vmap(make_train(cfg), axis_name=SEED_AXIS))(seed_keys(range(15)))``
    trains 15 seeds (without the axis name it gives the same result, computing every skipped
    update as well)."""
    trainer = Trainer(config)
    every = config.eval_every
    # the shell's chunks only mark checkpoints: one scan over the run's evaluation blocks, then
    # the few episodes short of a block, computes the same and compiles one copy of the block
    whole, rest = config.episodes // every * every, config.episodes % every

    def train(key: jax.Array):
        state = trainer.init(key)
        train_ms, eval_ms = [], []
        for n in (whole, rest):
            if n:
                state, tm, em = trainer.run_chunk(state, n)
                train_ms.append(tm)
                eval_ms.append(em)
        cat = lambda *xs: jnp.concatenate(xs)  # noqa: E731
        return state, jax.tree.map(cat, *train_ms), jax.tree.map(cat, *eval_ms)

    return train


_TRAINERS: dict[TrainConfig, Trainer] = {}


def make_trainer(config: TrainConfig) -> Trainer:
    """A :class:`Trainer` for ``config`` (a :class:`hiddpg.host.HostTrainer` for a Gymnasium
    task, ``gym:<id>``), shared by equal configs in this process so that its jitted functions
    compile once (the jit cache is keyed by the trainer object)."""
    try:
        hash(config)
    except TypeError:  # an unhashable env override value
        return _build(config)
    if config not in _TRAINERS:
        _TRAINERS[config] = _build(config)
    return _TRAINERS[config]


def _build(config: TrainConfig) -> Trainer:
    if isinstance(config.task, str) and config.task.startswith("gym:"):
        from hiddpg.host.trainer import HostTrainer  # the shell engine, with Gymnasium

        return HostTrainer(config)
    return Trainer(config)

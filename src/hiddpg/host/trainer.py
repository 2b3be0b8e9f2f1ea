"""The host-loop engine's trainer: :class:`HostTrainer`, the surface of
:class:`hiddpg.train.Trainer` for Gymnasium tasks (``TrainConfig.task = "gym:<name>"``).

The run loop (:mod:`hiddpg.runner`: run directories, checkpoints, ``--resume``, TensorBoard)
takes either trainer; :func:`hiddpg.train.make_trainer` builds this one for a ``gym:`` task.
The run state is the JAX engine's :class:`~hiddpg.train.RunState` (checkpoints have the same
form), its keys are split the same way, chunks have the same boundaries and the metrics the
same keys and shapes. Only the episodes differ: :class:`~hiddpg.host.loop.HostEpisodes` steps
the environments in Python, so there is no pure per-seed ``run_chunk`` (nor ``make_train``).

Example::

    config = dataclasses.replace(make_config("ddpg", "PuckTrajectory1", "quick"),
                                 task="gym:hiddpg/PuckTrajectory1-v0")
    trainer = HostTrainer(config)
    state = trainer.init_seeds(seed_keys([0, 1, 2]))
    state, train_metrics, eval_metrics = trainer.run_chunk_seeds(state, 10)
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from hiddpg.agents import make_agent
from hiddpg.configs import HIDDPGConfig, TrainConfig
from hiddpg.host.env import HostEnv, make_host_env
from hiddpg.host.loop import HostEpisodes, merge, one_seed, over_group, seed_groups, split, to_host
from hiddpg.host.task import gym_task
from hiddpg.train import RunState, Trainer


def _draw(key: jax.Array) -> tuple[jax.Array, jax.Array]:
    """The run's next key and the next episode's key, as the JAX engine draws them
    (``key, episode_key = split(key)``)."""
    key, episode_key = jax.random.split(key)
    return key, episode_key


#: :func:`_draw` compiled for a group of one seed (True) and of several (False)
_DRAW = {one: jax.jit(over_group(_draw, one)) for one in (True, False)}


@dataclasses.dataclass(frozen=True, eq=False)
class Engine:
    """What a host run computes with: the environment description, the agent, its training
    and evaluation episodes and the initial state of a batch of seeds."""

    env: HostEnv
    agent: Any
    train: HostEpisodes
    evaluate: HostEpisodes

    def __post_init__(self) -> None:
        object.__setattr__(self, "_init_one", jax.jit(self.init))

    def init_seeds(self, keys: jax.Array) -> RunState:
        """Every seed's untrained state, stacked: one jitted seed after another (compiling the
        ``vmap`` of an agent's initialisation takes several times as long, for a function
        called once a run; the values are the same)."""
        states = [self._init_one(keys[i]) for i in range(keys.shape[0])]
        return jax.tree.map(lambda *xs: jnp.stack(xs), *states)

    def init(self, key: jax.Array) -> RunState:
        """One seed's untrained state, drawn as :meth:`hiddpg.train.Trainer.init` draws it."""
        key, init_key = jax.random.split(key)
        agent_state = self.agent.init(init_key, self.env.params)
        return RunState(agent=agent_state, key=key, episode=jnp.zeros((), jnp.int32))


@dataclasses.dataclass(frozen=True, eq=False)
class HostTrainer:
    """Builds the Gymnasium task's :class:`~hiddpg.host.env.HostEnv` and the config's agent
    and trains every seed in its own environment (see module docstring)."""

    config: TrainConfig
    override: Callable[[Any], Any] | None = None
    """``agent -> agent``: replaces the agent the config builds (as for :class:`Trainer`)."""

    def __post_init__(self) -> None:
        engine = _engine(self.config) if self.override is None else None
        if engine is None:
            engine = _build_engine(self.config, self.override)
        for name, value in (("engine", engine), ("env", engine.env),
                            ("env_params", engine.env.params), ("agent", engine.agent),
                            ("_vectors", {})):
            object.__setattr__(self, name, value)

    #: the same chunk boundaries as the JAX engine
    chunk_sizes = Trainer.chunk_sizes

    def init(self, key: jax.Array) -> RunState:
        """One seed's untrained state (the JAX engine's for the same key)."""
        return self.engine.init(key)

    def init_seeds(self, keys: jax.Array) -> RunState:
        """The untrained state of every seed (leading axis), jitted."""
        return self.engine.init_seeds(keys)

    def vector(self, n_seeds: int) -> Any:
        """The vector environment of ``n_seeds`` environments (built once per size)."""
        if n_seeds not in self._vectors:
            self._vectors[n_seeds] = self.env.make_vector(n_seeds)
        return self._vectors[n_seeds]

    def close(self) -> None:
        """Close the vector environments (they are built again when needed)."""
        for vec in self._vectors.values():
            vec.close()
        self._vectors.clear()

    def run_chunk_seeds(self, state: RunState, n_episodes: int) -> tuple[RunState, dict, dict]:
        """Train every seed of ``state`` (leading axis) for ``n_episodes`` (a multiple of
        ``eval_every``, or fewer than it at the end), with a noise-free evaluation episode after
        every ``eval_every``. Returns the new state, training metrics with axes (seed, episode)
        and evaluation metrics with axes (seed, evaluation), as numpy arrays."""
        every = min(self.config.eval_every, n_episodes)
        if n_episodes % every:
            raise ValueError(
                f"a chunk of {n_episodes} episodes is not a multiple of eval_every={every}")
        n_seeds = jax.tree.leaves(state)[0].shape[0]
        groups = seed_groups(n_seeds)
        vec, parts = self.vector(n_seeds), split(state, groups)
        train_ms, eval_ms = [], []
        for _ in range(n_episodes // every):
            for _ in range(every):
                parts, keys = _next_keys(parts, groups)
                agents, metrics, _ = self.engine.train.run([p.agent for p in parts], keys, vec,
                                                           groups)
                parts = [RunState(agent=a, key=p.key, episode=p.episode + 1)
                         for a, p in zip(agents, parts, strict=True)]
                train_ms.append(_episode_row(metrics, parts, groups))
            parts, keys = _next_keys(parts, groups)
            _, metrics, _ = self.engine.evaluate.run([p.agent for p in parts], keys, vec, groups)
            eval_ms.append(_episode_row(metrics, parts, groups))
        return merge(parts, groups), _stack(train_ms), _stack(eval_ms)

    def evaluate_seeds(self, state: RunState, keys: jax.Array) -> tuple[dict, dict]:
        """Noise-free evaluation episode per seed from the episode keys ``keys``, with
        trajectories (axes seed, horizon, ...) for plots and GIFs."""
        groups = seed_groups(keys.shape[0])
        _, metrics, traj = self.engine.evaluate.run(split(state.agent, groups),
                                                    split(keys, groups),
                                                    self.vector(keys.shape[0]), groups)
        return jax.device_get((merge(metrics, groups), merge(traj, groups)))


def _build_engine(config: TrainConfig, override: Callable[[Any], Any] | None) -> Engine:
    env = make_host_env(config.task, **config.env_overrides)
    if isinstance(config.agent, HIDDPGConfig) and env.goal_space is None:
        raise ValueError(
            f"{config.algo} needs a goal space and {env.name} declares none: declare which "
            f"observation entries a goal fixes (indices 0..{env.obs_dim - 1}), on the command "
            f"line one --goal INDEX:LOW:HIGH per entry, in Python hiddpg.host."
            f"register_gym_task({env.name[4:]!r}, goal={{index: (low, high), ...}})")
    agent = make_agent(config.algo, config.agent, env)
    if override is not None:
        agent = override(agent)
    return Engine(env, agent, HostEpisodes(agent, env, train=True),
                  HostEpisodes(agent, env, train=False))


#: engines by what they are built from (not the run's length or chunks), so that equal configs
#: and a run extended by ``--resume --episodes N`` compile their steps once per process.
_ENGINES: dict[tuple, Engine] = {}


def _engine(config: TrainConfig) -> Engine | None:
    """The shared engine of ``config``; None if its parts cannot be a key (unhashable)."""
    key = (config.algo, gym_task(config.task), config.agent, config.env)
    try:
        hash(key)
    except TypeError:
        return None
    if key not in _ENGINES:
        _ENGINES[key] = _build_engine(config, None)
    return _ENGINES[key]


def _next_keys(parts: list[RunState], groups: list[slice]
               ) -> tuple[list[RunState], list[jax.Array]]:
    """Every group's next episode keys, drawn as the JAX engine draws them (only the keys
    enter the compiled call: the rest of the state is not copied)."""
    drawn = [_DRAW[one_seed(g)](p.key) for p, g in zip(parts, groups, strict=True)]
    return ([p.replace(key=d[0]) for p, d in zip(parts, drawn, strict=True)],
            [d[1] for d in drawn])


def _episode_row(metrics: list[dict], parts: list[RunState], groups: list[slice]
                 ) -> dict[str, np.ndarray]:
    """One episode's metrics of every seed, numpy arrays with the seed axis."""
    rows = jax.device_get([dict(m, episode=p.episode)
                           for m, p in zip(metrics, parts, strict=True)])
    return {k: np.concatenate([to_host(r[k], g) for r, g in zip(rows, groups, strict=True)])
            for k in rows[0]}


def _stack(rows: list[dict]) -> dict[str, np.ndarray]:
    """Per-episode dicts of (seed,) arrays as one dict of (seed, episode) arrays."""
    return {k: np.stack([r[k] for r in rows], axis=1) for k in rows[0]}

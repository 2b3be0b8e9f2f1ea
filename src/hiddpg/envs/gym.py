"""Gymnasium 1.x adapter around any functional core, and the ``hiddpg/`` registrations.

This is a shell module: it is the only place of :mod:`hiddpg.envs` that imports gymnasium, and
it is imported only when gymnasium is installed (see :mod:`hiddpg`).

>>> import gymnasium as gym, hiddpg
>>> env = gym.make("hiddpg/ArmReach-v0", field="cw")          # core params as keyword arguments
>>> obs, info = env.reset(seed=0, options={"target": (1.2, 1.0)})
"""

from __future__ import annotations

from typing import Any

import gymnasium
import jax
import jax.numpy as jnp
import numpy as np
from jax.flatten_util import ravel_pytree

from hiddpg.envs.base import Environment
from hiddpg.envs.bounds import ARM_MAX_SPEED, UNBOUNDED, unbounded
from hiddpg.envs.registry import TASKS, TaskSpec, make, spec_of, task_name

__all__ = ["ARM_MAX_SPEED", "UNBOUNDED", "HiddpgEnv", "env_ids", "observation_bounds",
           "register_envs"]


def observation_bounds(core: Environment, params: Any, spec: TaskSpec | None = None
                       ) -> tuple[np.ndarray, np.ndarray]:
    """The observation box: the declared ``obs_bounds`` of ``spec`` (default: the task that
    built ``core``), else ``core.observation_bounds(params)``, else ``±UNBOUNDED``."""
    spec = spec if spec is not None else spec_of(core)
    declared = spec.bounds_function() if spec is not None else None
    if declared is not None:
        low, high = declared(core, params)
    elif hasattr(core, "observation_bounds"):
        low, high = core.observation_bounds(params)
    else:
        low, high = unbounded(core, params)
    return np.asarray(low, np.float32), np.asarray(high, np.float32)


class _Program:
    """The jitted ``reset`` and ``step`` of one core and one params layout, shared by every
    adapter instance with that layout (see :func:`_program`).

    Two things keep a Python-level step cheap (docs/performance.md): the params travel as one
    flat array (``ravel_pytree``) instead of ~35 leaves, and the step's outputs (obs, reward,
    flags, info) come back to the host packed in one vector that is split again with numpy.
    """

    def __init__(self, core: Environment, params: Any) -> None:
        _, self.unravel = ravel_pytree(params)
        key = jax.random.PRNGKey(0)
        action = jnp.zeros(core.action_dim, jnp.float32)
        _, state = jax.eval_shape(core.reset, key, params)
        result = jax.eval_shape(core.step, key, state, action, params)
        leaves, self.treedef = jax.tree.flatten(self._outputs(result))
        self.specs = [(leaf.shape, np.dtype(leaf.dtype)) for leaf in leaves]
        self.offsets = np.cumsum([0] + [int(np.prod(shape)) for shape, _ in self.specs])
        self.dtype = jnp.result_type(jnp.float32, *[dt for _, dt in self.specs
                                                      if jnp.issubdtype(dt, jnp.floating)])

        def reset(key, flat_params, options):
            key, sub = jax.random.split(key)
            return key, core.reset(sub, self.unravel(flat_params), options)

        def step(key, state, action, flat_params):
            key, sub = jax.random.split(key)
            result = core.step(sub, state, action, self.unravel(flat_params))
            packed = [jnp.ravel(x).astype(self.dtype)
                      for x in jax.tree.leaves(self._outputs(result))]
            return key, result.state, jnp.concatenate(packed)

        self.reset, self.step = jax.jit(reset), jax.jit(step)

    @staticmethod
    def _outputs(result: Any) -> tuple:
        return result.obs, result.reward, result.terminated, result.truncated, result.info

    def unpack(self, packed: Any) -> tuple:
        """The packed vector to ``(obs, reward, terminated, truncated, info)`` with numpy
        arrays and Python scalars of the core's dtypes."""
        vector = np.asarray(packed)
        leaves = []
        for (shape, dtype), lo, hi in zip(self.specs, self.offsets[:-1], self.offsets[1:],
                                          strict=True):
            value = vector[lo:hi].astype(dtype).reshape(shape)
            leaves.append(value.item() if value.ndim == 0 else value)
        return jax.tree.unflatten(self.treedef, leaves)


_PROGRAMS: dict[Any, _Program] = {}


def _program(core: Environment, params: Any) -> tuple[_Program, jax.Array]:
    """The shared :class:`_Program` for ``(core, params)`` and the params as one flat array."""
    leaves, treedef = jax.tree.flatten(params)
    layout = (core, treedef, tuple((np.shape(x), jnp.result_type(x)) for x in leaves))
    if layout not in _PROGRAMS:
        _PROGRAMS[layout] = _Program(core, params)
    flat, _ = ravel_pytree(params)
    return _PROGRAMS[layout], flat


class HiddpgEnv(gymnasium.Env[np.ndarray, np.ndarray]):
    """Gymnasium view of a functional hiddpg task.

    Args:
        task: ``"ArmReach"``, ``"hiddpg/ArmReach-v0"`` or ``"ArmReach-v0"`` (see
            :data:`hiddpg.envs.TASKS`; :func:`hiddpg.register_task` adds tasks).
        render_mode: ``None`` or ``"rgb_array"`` (``render()`` returns an ``(H, W, 3)`` uint8
            frame drawn by :mod:`hiddpg.render`).
        **params: overrides of the core's params (``field="cw"``, ``dt=0.05``, ...); an unknown
            name raises ``ValueError`` naming it.

    Behaviour:
        * ``reset(seed=s)`` seeds ``np_random``; the episode's JAX PRNG key is drawn from it
          (two uint32 words) and each ``step`` splits that key, so equal seeds give equal
          episodes and ``step`` never touches ``np_random``.
        * ``reset``/``step`` are jitted once per core and params layout (shared between
          instances, so ``gym.make`` again does not recompile).
        * ``reset(options=...)`` forwards the options to the core (``ArmReach`` accepts
          ``{"target": (θ1, θ2)}`` in radians).
        * Actions are in the normalised box (``[-1, 1]`` for the puck, ``[0, 1]`` for muscle
          activations). An action of the wrong shape, or with a NaN or infinite entry, raises
          ``ValueError``. **Finite actions outside the box are clipped to it** (``5`` acts as
          ``1``), as the core does.
        * Episode ends come from the core (the puck trajectory terminates after 30 steps, the
          other tasks truncate at their horizon, collisions terminate), so the ids are registered
          without a ``TimeLimit`` wrapper: ``spec.max_episode_steps`` is ``None`` and the horizon
          is :attr:`max_steps` (it follows the ``max_steps`` param if one is passed).
        * ``info`` holds numpy arrays and Python scalars.

    Attributes:
        core, params: the functional environment and its params (use them with ``jax.vmap``).
        state: the core's state pytree of the running episode.
        max_steps: the horizon in control steps.
    """

    metadata: dict[str, Any] = {"render_modes": ["rgb_array"], "render_fps": 10}

    def __init__(self, task: str, render_mode: str | None = None, **params: Any) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode={render_mode!r} is not supported; choose one of "
                f"{self.metadata['render_modes']} or None"
            )
        self.task = task_name(task)
        self.core, self.params = make(self.task, **params)
        self.render_mode = render_mode
        dt = float(getattr(self.params, "dt", self.core.dt))  # the puck's dt is a parameter
        self.metadata = {**self.metadata, "render_fps": max(1, round(1.0 / dt))}
        self.max_steps = self.core.max_steps(self.params)
        low, high = observation_bounds(self.core, self.params, TASKS[self.task])
        self.observation_space = gymnasium.spaces.Box(low, high, (self.core.obs_dim,), np.float32)
        self.action_space = gymnasium.spaces.Box(
            np.float32(self.core.action_low), np.float32(self.core.action_high),
            (self.core.action_dim,), np.float32,
        )
        self._program, self._flat_params = _program(self.core, self.params)
        self.state: Any = None
        self.last_action: np.ndarray | None = None
        self.episode_return = 0.0
        self._key: jax.Array | None = None
        self._scene: Any = None
        self._trail: list[np.ndarray] = []

    # -- gymnasium API ------------------------------------------------------------------------
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        key = self.np_random.integers(0, 2**32, size=2, dtype=np.uint32)
        core_options = None
        if options:
            core_options = {k: jnp.asarray(v, jnp.float32) for k, v in options.items()}
        self._key, (obs, self.state) = self._program.reset(key, self._flat_params, core_options)
        self.last_action, self.episode_return, self._trail = None, 0.0, []
        return np.array(obs, np.float32), {}

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        if self.state is None:
            raise RuntimeError("call reset() before step()")
        action = self._check_action(action)
        self._key, self.state, packed = self._program.step(
            self._key, self.state, action, self._flat_params)
        self.last_action = action
        obs, reward, terminated, truncated, info = self._program.unpack(packed)
        self.episode_return += float(reward)
        return (np.asarray(obs, np.float32), float(reward), bool(terminated), bool(truncated),
                info)

    def render(self) -> np.ndarray | None:
        if self.render_mode is None:
            gymnasium.logger.warn(
                "render() called without a render_mode; make the env with render_mode='rgb_array'"
            )
            return None
        if self.state is None:
            raise RuntimeError("call reset() before render()")
        from hiddpg import render

        if self._scene is None:
            self._scene = render.Scene(self.core, self.params)
        self._trail.append(self._scene.position(self.state))
        text = [f"step {int(self.state.t):3d}   return {self.episode_return:8.2f}"]
        overlay = render.Overlay(trail=list(self._trail), text=text)
        return self._scene.frame(self.state, self.last_action, overlay)

    # -- helpers ------------------------------------------------------------------------------
    def _check_action(self, action: Any) -> np.ndarray:
        try:
            a = np.asarray(action, dtype=np.float32)
        except (TypeError, ValueError):
            raise ValueError(f"action {action!r} is not a numeric array") from None
        if a.shape != self.action_space.shape:
            raise ValueError(
                f"action {action!r} has shape {a.shape}; {self.task} expects "
                f"{self.action_space.shape}"
            )
        if not np.all(np.isfinite(a)):
            raise ValueError(f"action {action!r} has a NaN or infinite entry")
        return np.clip(a, self.action_space.low, self.action_space.high)

    def __repr__(self) -> str:
        return f"HiddpgEnv({self.task!r})"


def env_ids() -> list[str]:
    """Every registered id, e.g. ``hiddpg/ArmReach-v0``."""
    return [spec.env_id for spec in TASKS.values()]


def register_envs() -> None:
    """Register every task of :data:`hiddpg.envs.TASKS` under ``hiddpg/`` (idempotent).

    No ``max_episode_steps``: the cores end their episodes themselves (see :class:`HiddpgEnv`).
    """
    for spec in TASKS.values():
        if spec.env_id in gymnasium.registry:
            continue
        gymnasium.register(
            id=spec.env_id,
            entry_point="hiddpg.envs.gym:HiddpgEnv",
            kwargs={"task": spec.name},
            max_episode_steps=None,
            disable_env_checker=False,
        )

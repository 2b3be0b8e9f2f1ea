"""A Gymnasium environment as the agents see it: :class:`HostEnv`, built by :func:`make_host_env`.

An agent is built from a static environment description (``make_agent(algo, config, env)``):
it reads ``obs_dim``, ``action_dim``, the action box ``[action_low, action_high]`` its actions
lie in, ``dt`` (HI-DDPG's low-level model), ``goal_space`` (HI-DDPG) and, for h-DDPG, the skills.
:class:`HostEnv` presents exactly that for a Gymnasium environment, stepped on the host:

* the agent acts in ``[-1, 1]^n``, mapped affinely onto the environment's ``Box`` (our own
  tasks' adapters keep their normalised box, ``[-1, 1]`` or ``[0, 1]``, which is their ``Box``);
* observations are float32 vectors; rewards float32;
* the horizon is the environment's ``TimeLimit`` (or the declared ``max_episode_steps``).

What cannot work fails here, before anything is trained, with one line naming the value and
what is allowed: a discrete or unbounded action space, an observation that is not a 1-D Box,
a goal index outside the observation, an unknown horizon.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import gymnasium
import numpy as np

from hiddpg.envs.base import Environment, GoalSpace
from hiddpg.envs.gym import HiddpgEnv
from hiddpg.envs.registry import TASKS, resolve
from hiddpg.host.task import GymTask, gym_task


@dataclasses.dataclass(frozen=True, eq=False)
class HostEnv:
    """The static description of a Gymnasium task that agents are built from (see module
    docstring); :meth:`make_vector` builds the environments, one per seed.

    Attributes:
        name: the task, ``gym:<name>``.
        obs_dim, action_dim: sizes of the observation and action vectors.
        action_low, action_high: the box the agent's actions lie in (scalars).
        box_low, box_high: the environment's action ``Box``, onto which :meth:`to_box` maps.
        dt: the control period HI-DDPG's model scales by.
        goal_space: HI-DDPG's goal space, or None.
        horizon: the most steps an episode takes.
        params: what h-DDPG's skills get as ``env_params``.
        core: the functional core when the environment is one of our adapters, else None.
    """

    name: str
    obs_dim: int
    action_dim: int
    action_low: float
    action_high: float
    box_low: np.ndarray
    box_high: np.ndarray
    dt: float
    goal_space: GoalSpace | None
    horizon: int
    params: Any
    core: Environment | None
    skills: Any
    make_one: Callable[[], gymnasium.Env]
    vectorization: str
    make_render: Callable[[], gymnasium.Env] | None = None
    """Builds one environment with ``render_mode="rgb_array"`` (``hiddpg eval --gif``)."""

    def __post_init__(self) -> None:
        identity = bool(np.all(self.box_low == self.action_low)
                        and np.all(self.box_high == self.action_high))
        object.__setattr__(self, "_identity", identity)

    def max_steps(self, params: Any = None) -> int:
        """The horizon (the :class:`~hiddpg.envs.Environment` method agents may call)."""
        del params
        return self.horizon

    def to_box(self, action: Any) -> np.ndarray:
        """Actions ``(seeds, action_dim)`` in ``[action_low, action_high]`` mapped affinely onto
        the environment's ``Box`` and clipped to it (float rounding), in its dtype."""
        a = np.asarray(action)
        if not self._identity:
            w = (a.astype(np.float64) - self.action_low) / (self.action_high - self.action_low)
            a = self.box_low * (1.0 - w) + self.box_high * w
        return np.clip(a, self.box_low, self.box_high).astype(self.box_low.dtype)

    def declared_skills(self, config: Any) -> Any:
        """h-DDPG's :class:`~hiddpg.agents.skills.SkillPatterns` for ``config``
        (:func:`hiddpg.agents.skills.task_skills` asks here); ``ValueError`` if none declared."""
        from hiddpg.agents.skills import SkillPatterns

        if self.skills is None:
            raise ValueError(
                f"h-DDPG has no skill patterns for {self.name}: declare a factory "
                "(env, config) -> hiddpg.agents.skills.SkillPatterns, on the command line "
                "--skills MODULE:FUNCTION, in Python hiddpg.host.register_gym_task("
                f"{self.name[4:]!r}, skills=...)")
        factory = resolve(self.skills)
        skills = factory(self.core if self.core is not None else self, config)
        if not isinstance(skills, SkillPatterns):
            raise ValueError(f"the skills of {self.name} are a {type(skills).__name__}, not a "
                             "hiddpg.agents.skills.SkillPatterns")
        return skills

    def make_vector(self, n: int) -> gymnasium.vector.VectorEnv:
        """``n`` environments, one per seed, reset to the next step after an episode ends
        (Gymnasium's ``NEXT_STEP`` autoreset; the host loop masks those steps)."""
        fns = [self.make_one] * n
        if self.vectorization == "async":
            vec = gymnasium.vector.AsyncVectorEnv(fns, context="spawn")
        else:
            vec = gymnasium.vector.SyncVectorEnv(fns)
        mode = vec.metadata.get("autoreset_mode")
        if mode is not None and getattr(mode, "name", mode) not in ("NEXT_STEP", "next_step"):
            vec.close()
            raise RuntimeError(f"{self.name}: the vector environment resets in mode {mode}; "
                               "the host loop needs NEXT_STEP")
        return vec

    def __repr__(self) -> str:
        return f"HostEnv({self.name!r})"


def one_line(err: BaseException) -> str:
    """An error's message on one line."""
    return " ".join(str(err).split())


def _factory(task: GymTask, kwargs: dict[str, Any]) -> Callable[[], gymnasium.Env]:
    """A zero-argument builder of one environment: ``gymnasium.make`` of the id (a
    ``TimeLimit`` of ``max_episode_steps`` if declared) or the declared factory."""
    steps, env = task.max_episode_steps, task.env
    if isinstance(env, str):
        extra = {"max_episode_steps": steps} if steps is not None else {}
        return lambda: gymnasium.make(env, **kwargs, **extra)

    def build() -> gymnasium.Env:
        made = env(**kwargs)
        return made if steps is None else gymnasium.wrappers.TimeLimit(made, steps)

    return build


def _check_spaces(name: str, env: gymnasium.Env) -> None:
    act, obs = env.action_space, env.observation_space
    if not isinstance(act, gymnasium.spaces.Box):
        raise ValueError(f"{name}: the action space is {act}; HI-DDPG, h-DDPG and DDPG act in "
                         "a continuous gymnasium.spaces.Box (a discrete action space cannot "
                         "work)")
    if len(act.shape) != 1:
        raise ValueError(f"{name}: the action Box has shape {act.shape}; a 1-D Box is needed")
    if not (np.all(np.isfinite(act.low)) and np.all(np.isfinite(act.high))):
        raise ValueError(f"{name}: the action Box is unbounded (low={act.low.tolist()}, "
                         f"high={act.high.tolist()}); the agents need finite bounds")
    if not isinstance(obs, gymnasium.spaces.Box) or len(obs.shape) != 1:
        raise ValueError(f"{name}: the observation space is {obs}; a 1-D Box is needed "
                         "(gymnasium.wrappers.FlattenObservation flattens others)")


def _horizon(name: str, task: GymTask, env: gymnasium.Env) -> int:
    spec = getattr(env, "spec", None)
    for steps in (task.max_episode_steps, getattr(spec, "max_episode_steps", None),
                  getattr(env.unwrapped, "max_steps", None)):
        if steps is not None:
            return int(steps)
    raise ValueError(f"{name}: the horizon is unknown (no TimeLimit); declare it with "
                     f"hiddpg.host.register_gym_task({name[4:]!r}, max_episode_steps=N)")


def _check_goal(name: str, goal: GoalSpace | None, obs_dim: int) -> None:
    if goal is None:
        return
    bad = [i for i in goal.indices if i >= obs_dim]
    if bad:
        raise ValueError(f"{name}: goal index {bad[0]} is outside the observation "
                         f"(obs_dim={obs_dim}: indices 0..{obs_dim - 1})")


def make_host_env(task: str, **kwargs: Any) -> HostEnv:
    """The :class:`HostEnv` of the host-engine task ``task`` (``gym:<name>``, see
    :mod:`hiddpg.host.task`), ``kwargs`` passed to the environment. One environment is built
    to read its spaces, then closed. ``ValueError`` (one line) if the task cannot work."""
    declared = gym_task(task)
    make_one = _factory(declared, kwargs)
    try:
        env = make_one()
    except (gymnasium.error.Error, TypeError, ValueError, ImportError) as err:
        raise ValueError(f"{task}: cannot make the environment: {one_line(err)}") from None
    try:
        _check_spaces(task, env)
        horizon = _horizon(task, declared, env)
        unwrapped = env.unwrapped
        core = unwrapped.core if isinstance(unwrapped, HiddpgEnv) else None
        obs_dim, act = int(env.observation_space.shape[0]), env.action_space
        goal = declared.goal or (core.goal_space if core is not None else None)
        _check_goal(task, goal, obs_dim)
        skills = declared.skills
        if skills is None and core is not None:
            skills = TASKS[unwrapped.task].skills
        dt = declared.dt or (core.dt if core is not None else getattr(unwrapped, "dt", None))
        params = declared.params
        if params is None and core is not None:
            params = unwrapped.params
        low, high = ((float(core.action_low), float(core.action_high)) if core is not None
                     else (-1.0, 1.0))
        return HostEnv(
            name=task, obs_dim=obs_dim, action_dim=int(act.shape[0]), action_low=low,
            action_high=high, box_low=np.asarray(act.low), box_high=np.asarray(act.high),
            dt=float(dt) if dt else 1.0, goal_space=goal, horizon=horizon, params=params,
            core=core, skills=skills, make_one=make_one, vectorization=declared.vectorization,
            make_render=_factory(declared, {**kwargs, "render_mode": "rgb_array"}))
    finally:
        env.close()

"""The built-in movement patterns of h-DDPG's basic skills (paper §III-C, spec §4).

The paper gives every h-DDPG skill "prior knowledge": a fixed movement pattern whose intensity
its actor learns. A :class:`SkillPatterns` object is the static description of a task family's
``K`` patterns; its one pure function

``env_action(skill, unit, obs, env_params) -> normalised env action``

maps skill ``skill`` (an int, may be traced), the skill actor's unit output ``unit`` in
``[-1, 1]^actor_dim``, the observation and the environment params to the action the
environment takes (in its normalised box). ``actor_dims[k]`` is the output size skill ``k``
uses; the actors of all skills share the largest one (``actor_dim``) so that they can be stacked
and ``vmap``-ped, and a skill with fewer outputs ignores the extra ones.

* :class:`PuckSkills` — "the basic skills for h-DDPG assigned velocity directly to the puck
  (kinematics problem)" [paper]: skill ``k`` moves along ``d_k ∈ {+x, −x, +y, −y}`` at the speed
  ``m = v_max (u + 1) / 2 ≥ 0``; the force is the one that brings the velocity to ``m d_k`` in
  one step of ``v' = v + dt (−damping v + F)``, clipped to ``±force_max``, then normalised.
* :class:`ArmSkills` — S-F/Eb-F, S-F/Eb-Ex, S-Ex/Eb-F, S-Ex/Eb-Ex [paper]: the actor's outputs
  ``(u + 1) / 2 ∈ [0, 1]`` are the activations of the skill's agonists, all other muscles get 0
  [decision, spec §4].

A task declares its skills in the task registry (``skills=`` of :func:`hiddpg.register_task`, a
factory ``(env, config) -> SkillPatterns``); :func:`task_skills` builds them for an environment.

[decision] marks a value of ours where the paper is silent; docs/deviations.md (each with the
paper's value and why) lists them.
"""

from __future__ import annotations

import dataclasses
import re
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from hiddpg.envs.puckworld import POSITION
from hiddpg.envs.registry import TASKS, spec_of

#: PuckWorld skill directions ``d_k`` in the ``(x, y)`` plane [paper / spec §4].
PUCK_DIRECTIONS = ((1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0))
PUCK_SKILL_NAMES = ("+x", "-x", "+y", "-y")
#: The velocity entries of the PuckWorld state ``[x, y, vx, vy]``.
VELOCITY = slice(POSITION.stop, POSITION.stop + 2)

#: Muscle indices of the arm (order of :mod:`hiddpg.envs.muscles`).
SHOULDER_FLEXOR, SHOULDER_EXTENSOR, ELBOW_FLEXOR, ELBOW_EXTENSOR = 0, 1, 2, 3
BIARTICULAR_FLEXOR, BIARTICULAR_EXTENSOR = 4, 5
#: The agonists of each arm skill [paper names, decision muscles, spec §4].
ARM_AGONISTS = (
    (SHOULDER_FLEXOR, ELBOW_FLEXOR, BIARTICULAR_FLEXOR),  # S-F/Eb-F
    (SHOULDER_FLEXOR, ELBOW_EXTENSOR),  # S-F/Eb-Ex
    (SHOULDER_EXTENSOR, ELBOW_FLEXOR),  # S-Ex/Eb-F
    (SHOULDER_EXTENSOR, ELBOW_EXTENSOR, BIARTICULAR_EXTENSOR),  # S-Ex/Eb-Ex
)
ARM_SKILL_NAMES = ("S-F/Eb-F", "S-F/Eb-Ex", "S-Ex/Eb-F", "S-Ex/Eb-Ex")
ARM_MUSCLES = 6


class SkillPatterns:
    """Base class: ``names`` (one per skill), ``actor_dims`` (outputs each skill uses) and
    :meth:`env_action`. Subclasses are frozen dataclasses (static under ``jit``)."""

    names: tuple[str, ...]
    actor_dims: tuple[int, ...]

    @property
    def n_skills(self) -> int:
        """``K``, the number of skills."""
        return len(self.names)

    @property
    def actor_dim(self) -> int:
        """The shared actor output size (the largest skill's)."""
        return max(self.actor_dims)

    def env_action(
        self, skill: jax.Array, unit: jax.Array, obs: jax.Array, env_params: Any
    ) -> jax.Array:
        """The normalised environment action of skill ``skill`` for the unit output ``unit``
        (shape ``(actor_dim,)``) at ``obs``."""
        raise NotImplementedError


@dataclasses.dataclass(frozen=True)
class PuckSkills(SkillPatterns):
    """Velocity control along the four axis directions (see module docstring).

    Attributes:
        max_speed: ``v_max``, the speed of the unit output 1 (output -1 is speed 0).
    """

    max_speed: float = 3.0
    names: tuple[str, ...] = PUCK_SKILL_NAMES
    actor_dims: tuple[int, ...] = (1, 1, 1, 1)

    def __post_init__(self) -> None:
        if not self.max_speed > 0:
            raise ValueError(f"PuckSkills.max_speed={self.max_speed!r} must be > 0")

    def speed(self, unit: jax.Array) -> jax.Array:
        """``m = v_max (u + 1) / 2`` from the actor's first output, in ``[0, v_max]``."""
        return self.max_speed * (jnp.clip(unit[..., 0], -1.0, 1.0) + 1.0) * 0.5

    def target_velocity(self, skill: jax.Array, unit: jax.Array) -> jax.Array:
        """``m d_k``: the velocity skill ``k`` asks for."""
        return self.speed(unit) * jnp.asarray(PUCK_DIRECTIONS, jnp.float32)[skill]

    def force(self, skill: jax.Array, unit: jax.Array, obs: jax.Array, params: Any) -> jax.Array:
        """Solve ``m d_k = v + dt (−damping v + F)`` for ``F`` and clip it to ``±force_max``."""
        v = obs[VELOCITY]
        wanted = self.target_velocity(skill, unit)
        force = (wanted - v) / params.dt + params.damping * v
        return jnp.clip(force, -params.force_max, params.force_max)

    def env_action(self, skill, unit, obs, env_params):
        return self.force(skill, unit, obs, env_params) / env_params.force_max


@dataclasses.dataclass(frozen=True)
class ArmSkills(SkillPatterns):
    """Agonist-only activations (see module docstring).

    Attributes:
        agonists: the muscle indices each skill activates, in the order of its outputs.
    """

    agonists: tuple[tuple[int, ...], ...] = ARM_AGONISTS
    names: tuple[str, ...] = ARM_SKILL_NAMES

    @property
    def actor_dims(self) -> tuple[int, ...]:  # type: ignore[override]
        return tuple(len(a) for a in self.agonists)

    def selection(self) -> np.ndarray:
        """``(K, actor_dim, 6)`` 0/1 matrices: output ``j`` of skill ``k`` drives muscle
        ``agonists[k][j]``; the unused outputs of smaller skills drive nothing."""
        sel = np.zeros((self.n_skills, self.actor_dim, ARM_MUSCLES), np.float32)
        for k, muscles in enumerate(self.agonists):
            for j, m in enumerate(muscles):
                sel[k, j, m] = 1.0
        return sel

    def env_action(self, skill, unit, obs, env_params):
        activation = (jnp.clip(unit, -1.0, 1.0) + 1.0) * 0.5
        return activation @ jnp.asarray(self.selection())[skill]


def puck_skills(env: Any, config: Any) -> PuckSkills:
    """The PuckWorld tasks' skills, at the speed ``config.puck_max_speed``."""
    del env
    return PuckSkills(max_speed=config.puck_max_speed)


def arm_skills(env: Any, config: Any) -> ArmSkills:
    """The arm tasks' skills."""
    del env, config
    return ArmSkills()


def task_skills(env: Any, config: Any) -> SkillPatterns:
    """The skills ``env``'s registered task declares, built for the h-DDPG ``config``;
    ``ValueError`` saying what to declare if it declares none. An environment description
    that declares its own (:class:`hiddpg.host.env.HostEnv`) answers itself."""
    own = getattr(env, "declared_skills", None)
    if own is not None:
        return own(config)
    spec = spec_of(env)
    factory = spec.skill_factory() if spec is not None else None
    if factory is None:
        what = (f"task {spec.name!r} ({type(env).__name__})" if spec is not None
                else f"{type(env).__name__} (not a registered task)")
        raise ValueError(
            f"h-DDPG has no skill patterns for {what}: declare them with "
            "hiddpg.register_task(name, entry, skills=...), a factory (env, config) -> "
            "SkillPatterns (see hiddpg.agents.skills); tasks with skills: "
            f"{_compact([s.name for s in TASKS.values() if s.skills is not None])}")
    skills = factory(env, config)
    if not isinstance(skills, SkillPatterns):
        raise ValueError(f"the skills of task {spec.name!r} are a {type(skills).__name__}, "
                         "not a hiddpg.agents.skills.SkillPatterns")
    return skills


def skill_patterns(env: Any, puck_max_speed: float = 3.0) -> SkillPatterns:
    """:func:`task_skills` with the default h-DDPG config but ``puck_max_speed``."""
    from hiddpg.configs import HDDPGConfig

    return task_skills(env, HDDPGConfig(puck_max_speed=puck_max_speed))


def _compact(names: list[str]) -> str:
    """``PuckTrajectory1, PuckTrajectory2, PuckTrajectory3`` as ``PuckTrajectory1-3``."""
    out: list[list] = []
    for name in names:
        match = re.fullmatch(r"(.*?)(\d+)", name)
        stem, n = (match.group(1), int(match.group(2))) if match else (name, None)
        if out and n is not None and out[-1][0] == stem and out[-1][2] == n - 1:
            out[-1][2] = n
        else:
            out.append([stem, n, n])
    return ", ".join(stem if a is None else f"{stem}{a}" + (f"-{b}" if b != a else "")
                     for stem, a, b in out)

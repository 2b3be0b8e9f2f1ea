"""Goals and skills shipped for two Gymnasium environments, so that HI-DDPG and h-DDPG train
on them with nothing declared (``hiddpg train hi-ddpg Reacher-v5``):

* ``Reacher-v5`` (``gymnasium[mujoco]``): a two-joint planar arm whose fingertip must reach a
  target. **Goal**: observation entries 8 and 9, the fingertip's offset from the target
  (``x``, ``y``); a goal of 0 is the fingertip on the target. **Skills**: the four sign
  patterns of the two joint torques, shoulder (S) and elbow (E) each turning one way or the
  other, ``S+/E+``, ``S+/E-``, ``S-/E+``, ``S-/E-`` (the paper's arm skills S-F/Eb-F ... with
  torque motors for muscle pairs); each skill's two outputs set the two torques' magnitudes.
* ``myoElbowPose1D6MRandom-v0`` (MyoSuite, the ``myosuite`` extra): one elbow joint moved by
  six muscles, to be held at a random target angle. **Goal**: observation entry 0, the elbow
  angle. **Skills**: ``flex`` (biceps long and short heads and brachialis driven, the triceps
  off), ``extend`` (the three triceps heads driven, the flexors off) and ``co-contract`` (all
  six at one level: a stiffer joint). MyoSuite registers its ids when ``myosuite`` is
  imported, so the environment is made as ``myosuite:myoElbowPose1D6MRandom-v0`` (Gymnasium
  imports ``myosuite`` first); on the command line name it so, since a bare MyoSuite id is
  unknown until ``myosuite`` has been imported.

The declarations are data (:class:`~hiddpg.host.task.GymTask`; the skills are named
``"module:function"``): nothing here imports Gymnasium, MuJoCo or MyoSuite.
:func:`hiddpg.host.task.gym_task` falls back on :data:`CATALOG` for a name nobody registered;
``--goal``, ``--skills`` and :func:`~hiddpg.host.register_gym_task` replace these declarations.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from hiddpg.agents.skills import SkillPatterns
from hiddpg.host.task import GymTask

#: Reacher-v5's arm: link 0.1 plus fingertip 0.11 from the shoulder, so the fingertip lies
#: within 0.21 of the origin; the target is drawn uniformly in the disc of radius 0.2 (its
#: ``reset_model``). Each component of fingertip - target therefore lies in +-(0.21 + 0.2):
#: the bounds admit every offset the arm can have and no wider box.
REACHER_REACH = 0.21 + 0.2
REACHER_GOAL = {8: (-REACHER_REACH, REACHER_REACH), 9: (-REACHER_REACH, REACHER_REACH)}
#: The torque signs (shoulder, elbow) of Reacher's skills.
REACHER_SIGNS = ((1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0))
REACHER_SKILL_NAMES = ("S+/E+", "S+/E-", "S-/E+", "S-/E-")

#: MyoSuite's id and the form that imports ``myosuite`` first.
ELBOW_ID = "myoElbowPose1D6MRandom-v0"
ELBOW_ENV = "myosuite:" + ELBOW_ID
#: The elbow model's actuators, in action order (``myoelbow_1dof6muscles``): the triceps
#: (extensors) then biceps long and short heads and brachialis (flexors).
ELBOW_MUSCLES = ("TRIlong", "TRIlat", "TRImed", "BIClong", "BICshort", "BRA")
ELBOW_EXTENSORS, ELBOW_FLEXORS = (0, 1, 2), (3, 4, 5)
#: The observation is [elbow angle, angular velocity x dt, target - angle, 6 activations];
#: entry 0 is the angle, whose joint range in the model is [0, 2.26893] rad (and the random
#: targets are drawn in [0, 2.27]): the goal may be any angle the joint can take.
ELBOW_GOAL = {0: (0.0, 2.27)}
ELBOW_SKILL_NAMES = ("flex", "extend", "co-contract")


@dataclasses.dataclass(frozen=True)
class LinearSkills(SkillPatterns):
    """Skills whose actions are affine in the intensities ``(u + 1) / 2 in [0, 1]`` of their
    actor's outputs: skill ``k`` takes ``bias[k] + intensity @ weights[k]`` (in the agent's
    ``[-1, 1]`` action box, clipped to it by the host environment).

    Attributes:
        names: one per skill.
        weights: per skill, one row per actor output, one column per action entry.
        bias: per skill, the action when every intensity is 0.
    """

    names: tuple[str, ...]
    weights: tuple[tuple[tuple[float, ...], ...], ...]
    bias: tuple[tuple[float, ...], ...]

    def __post_init__(self) -> None:
        dims = {len(row) for w in self.weights for row in w} | {len(b) for b in self.bias}
        if not (len(self.names) == len(self.weights) == len(self.bias) and len(dims) == 1):
            raise ValueError("LinearSkills: names, weights and bias must have one entry per "
                             "skill, every row as long as the action")

    @property
    def actor_dims(self) -> tuple[int, ...]:  # type: ignore[override]
        return tuple(len(w) for w in self.weights)

    @property
    def action_dim(self) -> int:
        return len(self.bias[0])

    def matrices(self) -> tuple[np.ndarray, np.ndarray]:
        """``(K, actor_dim, action_dim)`` weights (zero rows for unused outputs) and
        ``(K, action_dim)`` biases."""
        w = np.zeros((self.n_skills, self.actor_dim, self.action_dim), np.float32)
        for k, rows in enumerate(self.weights):
            w[k, :len(rows)] = rows
        return w, np.asarray(self.bias, np.float32)

    def env_action(self, skill: jax.Array, unit: jax.Array, obs: jax.Array,
                   env_params: Any) -> jax.Array:
        w, b = self.matrices()
        intensity = (jnp.clip(unit, -1.0, 1.0) + 1.0) * 0.5
        return jnp.asarray(b)[skill] + intensity @ jnp.asarray(w)[skill]


def _check(env: Any, action_dim: int, name: str) -> None:
    got = getattr(env, "action_dim", action_dim)
    if got != action_dim:
        raise ValueError(f"the {name} skills drive {action_dim} actions; "
                         f"{getattr(env, 'name', env)} has {got}")


def reacher_skills(env: Any, config: Any) -> LinearSkills:
    """Reacher's torque-sign skills: skill ``k``'s outputs are the magnitudes (``[0, 1]`` of
    the torque box) of the shoulder and elbow torques, with the signs :data:`REACHER_SIGNS`."""
    del config
    _check(env, 2, "Reacher")
    weights = tuple(((s, 0.0), (0.0, e)) for s, e in REACHER_SIGNS)
    return LinearSkills(REACHER_SKILL_NAMES, weights, ((0.0, 0.0),) * 4)


def elbow_skills(env: Any, config: Any) -> LinearSkills:
    """The elbow's agonist skills: the driven muscles' commands are their outputs (in the
    action box ``[-1, 1]``, which MyoSuite maps to activations through its sigmoid), every
    other muscle is off (command -1, activation about 0.0006)."""
    del config
    _check(env, len(ELBOW_MUSCLES), "elbow")
    n = len(ELBOW_MUSCLES)

    def drive(*muscles: tuple[int, ...]) -> tuple[tuple[float, ...], ...]:
        return tuple(tuple(2.0 if m in group else 0.0 for m in range(n)) for group in muscles)

    weights = (drive(*((m,) for m in ELBOW_FLEXORS)), drive(*((m,) for m in ELBOW_EXTENSORS)),
               drive(ELBOW_FLEXORS + ELBOW_EXTENSORS))
    return LinearSkills(ELBOW_SKILL_NAMES, weights, ((-1.0,) * n,) * 3)


_ELBOW = GymTask(env=ELBOW_ENV, goal=ELBOW_GOAL, skills="hiddpg.host.catalog:elbow_skills",
                 summary="MyoSuite elbow, 6 muscles, random target angle (hiddpg.host.catalog)")
#: The shipped declarations, by the name after ``gym:``.
CATALOG: dict[str, GymTask] = {
    "Reacher-v5": GymTask(env="Reacher-v5", goal=REACHER_GOAL,
                          skills="hiddpg.host.catalog:reacher_skills",
                          summary="MuJoCo two-joint reacher (hiddpg.host.catalog)"),
    ELBOW_ENV: _ELBOW,
    ELBOW_ID: _ELBOW,
}


def catalogued(name: str) -> GymTask | None:
    """The shipped declaration of ``name`` (without ``gym:``), or None."""
    return CATALOG.get(name)

"""A 1-D point mass that must come to rest at a target, and two h-DDPG skills for it."""

import dataclasses

import jax
import jax.numpy as jnp
from flax import struct

import hiddpg
from hiddpg.agents.skills import SkillPatterns
from hiddpg.envs import Environment, GoalSpace, StepResult


@struct.dataclass
class SliderParams:
    target: float = 0.5
    max_steps: int = struct.field(pytree_node=False, default=40)


@struct.dataclass
class SliderState:
    x: jax.Array  # [position, velocity]
    t: jax.Array  # actions taken


class Slider(Environment):
    """A 1-D point mass that must come to rest at `target`."""

    name, obs_dim, state_dim, action_dim, dt = "Slider", 2, 2, 1, 0.1
    goal_space = GoalSpace(indices=(0,), low=(-1.0,), high=(1.0,))  # goals fix the position

    def default_params(self, **overrides):
        return SliderParams(**overrides)

    def dynamics(self, x, action, params):  # differentiable: used by iLQR
        force = self.clip_action(action)[0]
        return x + self.dt * jnp.stack([x[1], force - 0.5 * x[1]])

    def reset(self, key, params, options=None):
        state = SliderState(x=jnp.zeros(2), t=jnp.zeros((), jnp.int32))
        return state.x, state

    def step(self, key, state, action, params):
        x = self.dynamics(state.x, action, params)
        t = state.t + 1
        return StepResult(obs=x, state=SliderState(x=x, t=t),
                          reward=-jnp.abs(x[0] - params.target),
                          terminated=jnp.zeros((), bool), truncated=t >= params.max_steps,
                          info={})


@dataclasses.dataclass(frozen=True)
class PushSkills(SkillPatterns):
    """h-DDPG's skills: push right or push left; the skill's actor chooses how hard."""

    names: tuple[str, ...] = ("right", "left")
    actor_dims: tuple[int, ...] = (1, 1)

    def env_action(self, skill, unit, obs, env_params):
        strength = (jnp.clip(unit[:1], -1.0, 1.0) + 1.0) / 2.0
        return jnp.where(skill == 0, 1.0, -1.0) * strength


def slider_skills(env, config):
    return PushSkills()


hiddpg.register_task("Slider", Slider, skills=slider_skills,
                     summary="1-D point mass that comes to rest at 0.5")
